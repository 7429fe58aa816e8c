"""A seeded generator of broken copies of real OpenDS tasks, for the fuzz test.

Why: hand-written bad-input tests only find the failures someone thought of. Each mutant
takes one real task (corpus or drives) and changes one of its files in one way a hostile or
careless author might: a hostile number or string in a value, an element removed,
duplicated or renamed, the file cut short, a stray character, an entry naming another file.
"""

from __future__ import annotations

import random
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

HOSTILE_VALUES = (
    "inf", "-inf", "nan", "NaN", "1e308", "-1e308", "1e-320", "99999999999999999999", "-2147483649", "0", "-1",
    "", " ", "abc", "1_0", "١٢", "１０", "0x10", "true", "1.5", "-0.0", "1" * 400, "x" * 5000, "&amp;", "../../etc/passwd",
    "/etc/passwd", "Models/../../../../x.obj",
)  # fmt: skip
ENTRY_VALUES = (
    "../../../../etc/passwd", "/etc/passwd", "s" * 5000 + ".xml", "missing.xml", "", "scene.xml", "./settings.xml", "sub/../scene.xml",
)  # fmt: skip
_TEXT = re.compile(rb">([^<>]+)<")
_ATTR = re.compile(rb'(\w+)="([^"]*)"')
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)


@dataclass(frozen=True)
class Mutant:
    folder: Path
    file: str
    how: str


def task_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix in (".xml", ".xodr"))


def _replace_span(data: bytes, start: int, end: int, new: bytes) -> bytes:
    return data[:start] + new + data[end:]


def _structural(data: bytes, rng: random.Random, op: str) -> tuple[bytes, str] | None:
    try:
        root = etree.fromstring(data, _PARSER)
    except etree.XMLSyntaxError:
        return None
    elements = [e for e in root.iter() if isinstance(e.tag, str) and e is not root]
    if not elements:
        return None
    el = rng.choice(elements)
    parent = el.getparent()
    assert parent is not None
    if op == "delete":
        parent.remove(el)
    elif op == "duplicate":
        el.addnext(etree.fromstring(etree.tostring(el)))
    else:  # rename to another tag of the same file
        el.tag = rng.choice(elements).tag
    what = f"{op} <{etree.QName(el).localname}> line {el.sourceline}"
    return etree.tostring(root.getroottree(), xml_declaration=True, encoding="UTF-8"), what


def mutate(data: bytes, rng: random.Random, entry: bool) -> tuple[bytes, str]:
    """One mutation of a file's bytes and what it was."""
    ops = ["value", "value", "attr", "delete", "duplicate", "rename", "truncate", "char"]
    for _ in range(20):
        op = rng.choice(ops)
        if op in ("value", "attr"):
            spans = list((_TEXT if op == "value" else _ATTR).finditer(data))
            g = 1 if op == "value" else 2
            spans = [m for m in spans if m.group(g).strip() or op == "attr"]
            if not spans:
                continue
            m = rng.choice(spans)
            pool = ENTRY_VALUES if entry and op == "value" else HOSTILE_VALUES
            new = rng.choice(pool).encode()
            return _replace_span(data, m.start(g), m.end(g), new), f"{op} at byte {m.start(g)} -> {new[:30]!r}"
        if op == "truncate":
            n = rng.randrange(len(data))
            return data[:n], f"cut at byte {n}"
        if op == "char":
            n = rng.randrange(len(data))
            c = rng.choice(["<", ">", "&", '"', "\x00", "\u00e9", "]]>", "<!--"]).encode()
            return data[:n] + c + data[n:], f"insert {c!r} at byte {n}"
        out = _structural(data, rng, op)
        if out is not None:
            return out
    return data, "unchanged"


def make_mutant(src: Path, dst_root: Path, rng: random.Random, index: int) -> Mutant:
    """Copy task folder `src` under `dst_root` and mutate one of its files."""
    dst = dst_root / f"m{index:04d}" / src.name
    shutil.copytree(src, dst)
    files = task_files(dst)
    target = rng.choice(files)
    data = target.read_bytes()
    entry = b"<properties" in data[:2048]
    new, how = mutate(data, rng, entry)
    target.write_bytes(new)
    return Mutant(dst, target.name, how)
