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


def parse_file(path: Path) -> etree._Element:
    """Parse one XML file safely and return its root element.

    Raises TaskError naming the file and line for unreadable or malformed XML, and for
    documents that declare entities (entity expansion is never performed).
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise TaskError(f"cannot read file: {exc.strerror or exc}", file=path) from exc
    _reject_entity_declarations(data, path)
    try:
        tree = etree.fromstring(data, _parser(), base_url=None).getroottree()
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno else None
        raise TaskError(f"malformed XML: {exc.msg}", file=path, line=line) from exc
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
