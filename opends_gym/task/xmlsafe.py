"""Safe XML reading for user-supplied task files.

Why: task files come from anywhere. Real ones name a java.sun.com DTD that must never be
fetched, and hostile ones may carry entity bombs or external entities. lxml is told not
to resolve entities, not to load DTDs and never to touch the network; any entity
declaration is rejected outright with a clear error.
"""

from __future__ import annotations

import re
from pathlib import Path

from lxml import etree

from .errors import TaskError

# Caps on one task file, far above the largest real OpenDS task (the corpus's largest file,
# opends-cts ReactionTest/scene.xml, is 3.1 MB with 49,042 elements) and far below what makes
# a load slow: an 18 MB scene of 300,000 models took 8.8 s and 575 MB before these caps (issue 21);
# benchmarks/hostile_task.py measures how fast such scenes are refused now.
MAX_FILE_BYTES = 16 * 1024 * 1024
MAX_ELEMENTS = 250_000


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        dtd_validation=False,
        huge_tree=False,
        remove_comments=True,
        remove_pis=True,
    )


def local_name(element: etree._Element) -> str:
    """Tag without its namespace (`{http://opends.eu/...}model` -> `model`)."""
    tag = element.tag
    if not isinstance(tag, str):
        return ""
    return tag.rsplit("}", 1)[-1]


_ENTITY_DECL = re.compile(rb"<!ENTITY\s+%?\s*([^\s>]+)")


def _reject_entity_declarations(data: bytes, path: Path) -> None:
    """Refuse entity declarations before libxml2 sees them (billion laughs, XXE)."""
    match = _ENTITY_DECL.search(data)
    if match is None:
        return
    line = data.count(b"\n", 0, match.start()) + 1
    name = match.group(1).decode("utf-8", "replace")
    raise TaskError(
        f"the document declares the entity '{name}'; entity declarations are not allowed in driving-task files and are never expanded",
        file=path,
        line=line,
        element="!ENTITY",
    )


_START_TAG = re.compile(rb"<([^!?/\s>]+)")


def _reject_too_many_elements(data: bytes, path: Path) -> None:
    """Count start tags before parsing (a parse tree costs ~15 times the file in memory).

    Tags inside comments and CDATA count too: an overcount that matters only near the cap."""
    for count, match in enumerate(_START_TAG.finditer(data), start=1):
        if count > MAX_ELEMENTS:
            line = data.count(b"\n", 0, match.start()) + 1
            tag = match.group(1).decode("utf-8", "replace").rsplit(":", 1)[-1][:40]
            msg = f"more than {MAX_ELEMENTS:,} elements in one file (the cap; real OpenDS tasks have under 50,000)"
            raise TaskError(msg, file=path, line=line, element=tag)


def _read_capped(path: Path) -> bytes:
    """The file's bytes, refusing files over MAX_FILE_BYTES before reading them."""
    try:
        with path.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise TaskError(f"cannot read file: {exc.strerror or exc}", file=_short(path)) from exc
    if len(data) > MAX_FILE_BYTES:
        cap = MAX_FILE_BYTES // (1024 * 1024)
        raise TaskError(f"file is larger than {cap} MiB (the cap; real OpenDS task files are under 4 MB)", file=path)
    return data


def _short(path: Path, limit: int = 200) -> str:
    """A path for a one-line message (a hostile name may be thousands of characters)."""
    s = str(path)
    return s if len(s) <= limit else s[:100] + "..." + s[-60:]


def parse_file(path: Path) -> etree._Element:
    """Parse one XML file safely and return its root element.

    Raises TaskError naming the file and line for unreadable or malformed XML, and for
    documents that declare entities (entity expansion is never performed).
    """
    data = _read_capped(path)
    _reject_entity_declarations(data, path)
    _reject_too_many_elements(data, path)
    try:
        tree = etree.fromstring(data, _parser(), base_url=None).getroottree()
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno else None
        msg = " ".join(str(exc.msg).split()).removesuffix(f", line {line}, column {exc.position[1]}") if line else str(exc.msg)
        raise TaskError(f"malformed XML: {' '.join(msg.split())}", file=path, line=line) from exc
    docinfo = tree.docinfo
    dtd = docinfo.internalDTD
    if dtd is not None:
        entities = list(dtd.iterentities())
        if entities:
            name = entities[0].name
            raise TaskError(
                f"the document declares entities (first: '{name}'); entity declarations "
                "are not allowed in driving-task files and are never expanded",
                file=path,
                line=1,
                element="!DOCTYPE",
            )
    root = tree.getroot()
    for node in root.iter():
        if isinstance(node, etree._Entity):
            raise TaskError(
                f"entity reference '&{node.name};' is not allowed in driving-task files",
                file=path,
                line=node.sourceline,
                element=local_name(node.getparent()) if node.getparent() is not None else None,
            )
    return root
