"""The task's entry file: a Java-properties XML naming the four layer files.

Why: OpenDS opens a task through this file (`reactionTest.xml`, `paris.xml`...). Users
may hand us the folder or the file, so we also find the entry file inside a folder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from .bind import children
from .errors import Diagnostics, TaskError
from .xmlsafe import local_name, parse_file

LAYER_KEYS = ("scene", "scenario", "interaction", "settings", "task", "openDrive")
REQUIRED_KEYS = ("scene", "scenario")


@dataclass(frozen=True)
class EntryFile:
    """What the entry file says: layer file names relative to the task folder."""

    file_name: str
    scene: str
    scenario: str
    interaction: str | None = None
    settings: str | None = None
    task: str | None = None
    open_drive: str | None = None
    verbose: bool = False
    comment: str | None = None
    other: tuple[tuple[str, str], ...] = ()
    lines: tuple[tuple[str, int], ...] = field(default=(), compare=False, repr=False)

    def line_of(self, key: str) -> int | None:
        """The entry file's line naming layer `key`, for messages."""
        return dict(self.lines).get(key)

    def layer_file(self, key: str) -> str | None:
        return {
            "scene": self.scene,
            "scenario": self.scenario,
            "interaction": self.interaction,
            "settings": self.settings,
            "task": self.task,
            "openDrive": self.open_drive,
        }[key]


def _is_entry_file(path: Path) -> bool:
    try:
        with path.open("rb") as fh:
            head = fh.read(2048)
    except OSError:
        return False
    return b"<properties" in head


def find_entry_file(path: Path) -> Path:
    """The entry file of a task given as its folder or the file itself."""
    if path.is_file():
        return path
    if not path.is_dir():
        raise TaskError("no such task file or folder", file=path)
    candidates = sorted(p for p in path.glob("*.xml") if _is_entry_file(p))
    if not candidates:
        raise TaskError(
            "no entry file (a Java-properties XML naming scene, scenario, interaction and settings) in this folder",
            file=path,
        )
    if len(candidates) == 1:
        return candidates[0]
    named = [p for p in candidates if p.stem.lower() == path.name.lower()]
    if len(named) == 1:
        return named[0]
    raise TaskError(
        "several entry files here (" + ", ".join(p.name for p in candidates) + "); pass one of them",
        file=path,
    )


def _parse_bool(text: str, el: etree._Element, file: Path, diag: Diagnostics) -> bool:
    t = text.strip().lower()
    if t in ("true", "false"):
        return t == "true"
    # Java's Boolean.parseBoolean reads anything but "true" as false; OpenDS runs on.
    diag.warn(f"'{text}' is not true/false; read as false, as OpenDS does", file=file, line=el.sourceline, element="entry")
    return False


def read_entry_file(path: Path, diag: Diagnostics) -> EntryFile:
    root = parse_file(path)
    if local_name(root) != "properties":
        raise TaskError(
            f"entry file root must be <properties>, found <{local_name(root)}>", file=path, line=root.sourceline, element=local_name(root)
        )
    values: dict[str, str] = {}
    lines: dict[str, int] = {}
    other: list[tuple[str, str]] = []
    verbose = False
    comment = None
    for el in children(root):
        name = local_name(el)
        if name == "comment":
            comment = (el.text or "").strip()
            continue
        if name != "entry":
            diag.warn(f"unknown element <{name}> ignored", file=path, line=el.sourceline, element=name)
            continue
        key = el.get("key")
        if key is None:
            raise TaskError("missing required attribute 'key'", file=path, line=el.sourceline, element="entry")
        text = (el.text or "").strip()
        if key == "verbose":
            verbose = _parse_bool(text, el, path, diag)
        elif key in LAYER_KEYS:
            if key in values:
                diag.warn(f"entry '{key}' given twice; the last one is used", file=path, line=el.sourceline, element="entry")
            values[key] = text
            lines[key] = el.sourceline or 0
        else:
            other.append((key, text))
    for key in REQUIRED_KEYS:
        if not values.get(key):
            raise TaskError(f'missing required entry key="{key}"', file=path, line=root.sourceline, element="properties")
    return EntryFile(
        file_name=path.name,
        scene=values["scene"],
        scenario=values["scenario"],
        interaction=values.get("interaction") or None,
        settings=values.get("settings") or None,
        task=values.get("task") or None,
        open_drive=values.get("openDrive") or None,
        verbose=verbose,
        comment=comment,
        other=tuple(other),
        lines=tuple(lines.items()),
    )


def write_entry_file(entry: EntryFile, path: Path) -> None:
    root = etree.Element("properties")
    root.set("version", "1.0")
    if entry.comment is not None:
        etree.SubElement(root, "comment").text = entry.comment
    for key in LAYER_KEYS:
        value = entry.layer_file(key)
        if value:
            e = etree.SubElement(root, "entry")
            e.set("key", key)
            e.text = value
    e = etree.SubElement(root, "entry")
    e.set("key", "verbose")
    e.text = "true" if entry.verbose else "false"
    for key, value in entry.other:
        e = etree.SubElement(root, "entry")
        e.set("key", key)
        e.text = value
    data = etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8", standalone=False)
    # The DOCTYPE OpenDS writes; we never fetch it when reading.
    data = data.replace(
        b"?>\n",
        b'?>\n<!DOCTYPE properties SYSTEM "http://java.sun.com/dtd/properties.dtd">\n',
        1,
    )
    path.write_bytes(data)
