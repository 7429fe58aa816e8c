"""Strict mode: validate each layer file against the OpenDS XSD of its version.

Why: OpenDS itself is lenient, but authors of new tasks want to know when a file strays
from the schema (a misspelt element is silently ignored otherwise). The XSDs are not
bundled; they are found beside the task as OpenDS lays them out (`../Schema`,
`../../Schema`, or the file's own `xsi:schemaLocation`), or passed as `schema_dir`.
"""

from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path

from lxml import etree

from .errors import TaskError

XSI = "{http://www.w3.org/2001/XMLSchema-instance}"


def _candidates(file: Path, root: etree._Element, layer: str, schema_dir: str | Path | None) -> list[Path]:
    if schema_dir is not None:
        return [Path(schema_dir) / f"{layer}.xsd"]
    out = []
    loc = root.get(XSI + "schemaLocation")
    if loc:
        parts = loc.split()
        if len(parts) >= 2:
            out.append((file.parent / parts[-1]).resolve())
    for up in ("../Schema", "../../Schema"):
        out.append((file.parent / up / f"{layer}.xsd").resolve())
    return out


@lru_cache(maxsize=32)
def _schema(path: Path) -> etree.XMLSchema:
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    return etree.XMLSchema(etree.parse(str(path), parser))


_ELEMENT = re.compile(r"Element '(?:\{[^}]*\})?([^']+)'")


def validate_against_xsd(file: Path, root: etree._Element, layer: str, schema_dir: str | Path | None) -> None:
    """Raise TaskError at the first schema violation (file, line, element)."""
    cands = _candidates(file, root, layer, schema_dir)
    xsd = next((c for c in cands if c.is_file()), None)
    if xsd is None:
        raise TaskError(
            f"strict mode: no {layer}.xsd found (looked in " + ", ".join(str(c.parent) for c in cands) + "); pass schema_dir",
            file=file,
        )
    try:
        schema = _schema(xsd)
    except etree.XMLSchemaParseError as exc:
        raise TaskError(f"strict mode: cannot read schema {xsd}: {exc}", file=file) from exc
    if schema.validate(root.getroottree()):
        return
    err = schema.error_log[0]
    m = _ELEMENT.search(err.message)
    raise TaskError(f"does not match {xsd.name}: {err.message}", file=file, line=err.line or None, element=m.group(1) if m else None)
