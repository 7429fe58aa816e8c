"""Declarative binding between OpenDS XML elements and frozen dataclasses.

Why: every model field declares once where it lives in the XML and how its text converts
(with units) to an SI value. The same declaration drives loading and saving, so
`load_task(save_task(load_task(x))) == load_task(x)` holds by construction rather than
by keeping two hand-written code paths in step.

Field paths: `@attr` (attribute), `child` or `a/b` (element text or nested element),
`.` (the element's own text). A list field names a wrapper path (or `.`) and the item
tags it collects.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import MISSING, dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

from lxml import etree

from .errors import Diagnostics, TaskError
from .xmlsafe import local_name

T = TypeVar("T")

JAVA_FLOAT_MAX = 3.4028234663852886e38  # Float.MAX_VALUE


@dataclass
class ReadCtx:
    """Where we are while reading: the file (for messages) and the warning sink."""

    file: Path
    diag: Diagnostics

    def error(self, message: str, el: etree._Element | None, element: str | None = None) -> TaskError:
        line = el.sourceline if el is not None else None
        name = element if element is not None else (local_name(el) if el is not None else None)
        return TaskError(message, file=self.file, line=line, element=name)

    def warn(self, message: str, el: etree._Element | None, element: str | None = None, once_key: str | None = None) -> None:
        line = el.sourceline if el is not None else None
        name = element if element is not None else (local_name(el) if el is not None else None)
        self.diag.warn(message, file=self.file, line=line, element=name, once_key=once_key)


@dataclass
class WriteCtx:
    """The namespace of the layer document being written."""

    ns: str

    def sub(self, parent: etree._Element, tag: str) -> etree._Element:
        return etree.SubElement(parent, f"{{{self.ns}}}{tag}" if self.ns else tag)


# --------------------------------------------------------------------------- scalars


class Scalar(Generic[T]):
    """Text <-> value conversion for attributes and simple elements."""

    kind = "text"

    def parse(self, text: str) -> T:
        raise NotImplementedError

    def format(self, value: T) -> str:
        raise NotImplementedError

    def empty(self) -> Any:
        """Value of an empty element/attribute; MISSING means 'use the default'."""
        return MISSING


class Str(Scalar[str]):
    kind = "string"

    def parse(self, text: str) -> str:
        return text.strip()

    def format(self, value: str) -> str:
        return value

    def empty(self) -> Any:
        return ""


class Float(Scalar[float]):
    """A float; `scale` converts the file's unit to SI (file value * scale)."""

    kind = "number"

    def __init__(self, scale: float = 1.0) -> None:
        self.scale = scale

    def parse(self, text: str) -> float:
        value = float(text.strip())
        # OpenDS reads these with Java's Float.parseFloat: beyond the float range they are
        # Infinity there, so they are refused here like inf and nan.
        if not math.isfinite(value) or abs(value) > JAVA_FLOAT_MAX:
            raise ValueError(text)
        return value * self.scale if self.scale != 1.0 else value

    def format(self, value: float) -> str:
        if self.scale == 1.0:
            v = float(value)
            # integral values print as "20", which the XSDs' integer types accept
            return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)
        # 12 significant digits give back the file's own literal, so a reload
        # divides the same number by the same scale and lands on the same float.
        return f"{value / self.scale:.12g}"


class Int(Scalar[int]):
    """A Java `int`: OpenDS reads these with `Integer.parseInt`, so values outside
    [-2^31, 2^31-1] (and inf/nan/1e308 written as floats) are refused, not wrapped."""

    kind = "integer"
    MIN, MAX = -(2**31), 2**31 - 1

    def parse(self, text: str) -> int:
        t = text.strip()
        try:
            value = int(t)
        except ValueError:
            f = float(t)  # tolerate "2.0" as OpenDS's Float parsing would
            if not math.isfinite(f) or f != int(f):
                raise
            value = int(f)
        if not self.MIN <= value <= self.MAX:
            raise ValueError(t)
        return value

    def format(self, value: int) -> str:
        return str(int(value))


class Bool(Scalar[bool]):
    kind = "boolean (true/false)"

    def parse(self, text: str) -> bool:
        t = text.strip().lower()
        if t in ("true", "1"):
            return True
        if t in ("false", "0"):
            return False
        raise ValueError(text)

    def format(self, value: bool) -> str:
        return "true" if value else "false"


class Choice(Scalar[str]):
    """One of a fixed set of words (case-insensitive match, canonical spelling kept)."""

    def __init__(self, *choices: str) -> None:
        self.choices = choices
        self.kind = "one of " + "|".join(choices)

    def parse(self, text: str) -> str:
        t = text.strip()
        for c in self.choices:
            if c.lower() == t.lower():
                return c
        raise ValueError(text)

    def format(self, value: str) -> str:
        return value


STR = Str()
FLOAT = Float()
INT = Int()
BOOL = Bool()
KMH = Float(1.0 / 3.6)  # km/h in the file, m/s in the model
MS = Float(1e-3)  # milliseconds in the file, seconds in the model
DEG = Float(math.pi / 180.0)  # degrees in the file, radians in the model
CM3 = Float(1e-6)  # cubic centimetres in the file, cubic metres in the model


# --------------------------------------------------------------------------- elements


class Node(Generic[T]):
    """Element <-> value conversion for structured content."""

    def read(self, el: etree._Element, ctx: ReadCtx) -> T:
        raise NotImplementedError

    def write(self, el: etree._Element, value: T, ctx: WriteCtx) -> None:
        raise NotImplementedError

    def owns(self, value: Any) -> bool:
        """Whether a list item `value` is written by this codec (for mixed lists)."""
        return True


class Struct(Node[T]):
    """A nested dataclass read with its own field bindings."""

    def __init__(self, cls: type[T]) -> None:
        self.cls = cls

    def read(self, el: etree._Element, ctx: ReadCtx) -> T:
        return read_struct(self.cls, el, ctx)

    def write(self, el: etree._Element, value: T, ctx: WriteCtx) -> None:
        write_struct(value, el, ctx)

    def owns(self, value: Any) -> bool:
        return isinstance(value, self.cls)


class Custom(Node[T]):
    """A codec from two functions, for the few shapes a path cannot express."""

    def __init__(
        self,
        reader: Callable[[etree._Element, ReadCtx], T],
        writer: Callable[[etree._Element, T, WriteCtx], None],
        owns: Callable[[Any], bool] | None = None,
    ) -> None:
        self._reader, self._writer, self._owns = reader, writer, owns

    def read(self, el: etree._Element, ctx: ReadCtx) -> T:
        return self._reader(el, ctx)

    def write(self, el: etree._Element, value: T, ctx: WriteCtx) -> None:
        self._writer(el, value, ctx)

    def owns(self, value: Any) -> bool:
        return self._owns(value) if self._owns else True


class TextNode(Node[T]):
    """An element whose text is a scalar (used for list items like `<wp>id</wp>`)."""

    def __init__(self, scalar: Scalar[T]) -> None:
        self.scalar = scalar

    def read(self, el: etree._Element, ctx: ReadCtx) -> T:
        return parse_scalar(self.scalar, el.text or "", el, ctx)

    def write(self, el: etree._Element, value: T, ctx: WriteCtx) -> None:
        el.text = self.scalar.format(value)


@dataclass(frozen=True)
class RawElement:
    """An element kept verbatim (blocks we do not interpret but must write back)."""

    tag: str
    attrib: tuple[tuple[str, str], ...] = ()
    text: str = ""
    children: tuple[RawElement, ...] = ()

    def find(self, tag: str) -> RawElement | None:
        return next((c for c in self.children if c.tag == tag), None)


def _read_raw(el: etree._Element, ctx: ReadCtx) -> RawElement:
    return RawElement(
        tag=local_name(el),
        attrib=tuple(sorted((k, v) for k, v in el.attrib.items() if not k.startswith("{"))),
        text=(el.text or "").strip(),
        children=tuple(_read_raw(c, ctx) for c in el if isinstance(c.tag, str)),
    )


def _write_raw(el: etree._Element, value: RawElement, ctx: WriteCtx) -> None:
    for k, v in value.attrib:
        el.set(k, v)
    if value.text:
        el.text = value.text
    for c in value.children:
        _write_raw(ctx.sub(el, c.tag), c, ctx)


RAW: Node[RawElement] = Custom(_read_raw, _write_raw, lambda v: isinstance(v, RawElement))


# --------------------------------------------------------------------------- bindings


@dataclass(frozen=True)
class Bind:
    """Where a field lives and how it converts. Built by `attr`, `elem`, `elems`."""

    path: str
    codec: Scalar[Any] | Node[Any] | None = None
    items: Mapping[str, Node[Any]] | None = None  # list field: item tag -> codec
    required: bool = False
    extras: bool = False  # collect every child no other field consumed (RawElement)
    keep: bool = False  # write even when equal to the default (the XSD requires it)

    @property
    def head(self) -> str:
        return self.path.split("/", 1)[0]


def attr(name: str, codec: Scalar[Any] = STR, default: Any = None, required: bool = False, keep: bool = False) -> Any:
    """A field stored in an attribute of the element."""
    return field(default=default, metadata={"xml": Bind("@" + name, codec, required=required, keep=keep)})


def elem(path: str, codec: Scalar[Any] | Node[Any], default: Any = None, required: bool = False, keep: bool = False) -> Any:
    """A field stored in a child element (its text, or its structure for a Node codec).

    When saving, a value equal to `default` is left out (reading gives it back) unless
    `keep` is set because the OpenDS schema requires the element.
    """
    return field(default=default, metadata={"xml": Bind(path, codec, required=required, keep=keep)})


def elems(wrapper: str, items: Mapping[str, Node[Any]] | tuple[str, Node[Any]], required: bool = False) -> Any:
    """A tuple field of the child elements with the given tags, under `wrapper` (or `.`)."""
    mapping = dict([items]) if isinstance(items, tuple) else dict(items)
    return field(default=(), metadata={"xml": Bind(wrapper, items=mapping, required=required)})


def extras() -> Any:
    """A tuple of RawElement holding every child no other field reads (kept for saving)."""
    return field(default=(), metadata={"xml": Bind("*", extras=True)})


def source_line() -> Any:
    """The element's line in its file, for messages; ignored by equality."""
    return field(default=0, compare=False, repr=False, metadata={"line": True})


# --------------------------------------------------------------------------- reading


def parse_scalar(codec: Scalar[T], text: str, el: etree._Element, ctx: ReadCtx, what: str | None = None) -> T:
    try:
        return codec.parse(text)
    except (ValueError, TypeError, OverflowError):
        name = what or local_name(el)
        raise ctx.error(f"'{shown(text)}' is not a valid {codec.kind} for {name}", el) from None


def shown(text: str, limit: int = 60) -> str:
    """`text` for a one-line message: stripped, newlines folded, cut to `limit` characters."""
    t = " ".join(text.split())
    return t if len(t) <= limit else t[: limit - 3] + "..."


def children(el: etree._Element, tag: str | None = None) -> list[etree._Element]:
    """Element children (comments skipped), optionally only those with local name `tag`."""
    return [c for c in el if isinstance(c.tag, str) and (tag is None or local_name(c) == tag)]


def _descend(el: etree._Element, segments: Iterable[str], ctx: ReadCtx) -> etree._Element | None:
    node: etree._Element | None = el
    for seg in segments:
        if node is None:
            return None
        found = children(node, seg)
        if len(found) > 1:
            ctx.warn(f"<{seg}> appears {len(found)} times; the first is used", found[1], seg)
        node = found[0] if found else None
    return node


def _read_bind(b: Bind, el: etree._Element, ctx: ReadCtx) -> Any:
    segs = b.path.split("/")
    if b.items is not None:
        wrapper = el if b.path == "." else _descend(el, segs, ctx)
        if wrapper is None:
            if b.required:
                raise ctx.error(f"missing required element <{b.path}>", el)
            return MISSING
        out = []
        for c in children(wrapper):
            name = local_name(c)
            codec = b.items.get(name)
            if codec is None:
                if wrapper is not el:
                    ctx.warn(f"unknown element <{name}> in <{local_name(wrapper)}> ignored", c)
                continue
            out.append(codec.read(c, ctx))
        if b.required and not out:
            raise ctx.error(f"<{local_name(wrapper)}> needs at least one of " + ", ".join(f"<{t}>" for t in b.items), wrapper)
        return tuple(out)
    if segs[-1].startswith("@"):
        holder = _descend(el, segs[:-1], ctx)
        name = segs[-1][1:]
        raw = holder.get(name) if holder is not None else None
        if raw is None:
            if b.required:
                raise ctx.error(f"missing required attribute '{name}'", holder if holder is not None else el)
            return MISSING
        assert isinstance(b.codec, Scalar)
        if not raw.strip():
            return b.codec.empty()
        return parse_scalar(b.codec, raw, holder if holder is not None else el, ctx, f"attribute '{name}'")
    node = el if b.path == "." else _descend(el, segs, ctx)
    if node is None:
        if b.required:
            raise ctx.error(f"missing required element <{b.path}>", el)
        return MISSING
    if isinstance(b.codec, Scalar):
        text = node.text or ""
        if not text.strip():
            return b.codec.empty()
        return parse_scalar(b.codec, text, node, ctx)
    assert b.codec is not None
    return b.codec.read(node, ctx)


def read_struct(cls: type[T], el: etree._Element, ctx: ReadCtx) -> T:
    """Build dataclass `cls` from element `el` using its fields' bindings."""
    kwargs: dict[str, Any] = {}
    consumed: set[str] = set()
    extras_field: str | None = None
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        if f.metadata.get("line"):
            kwargs[f.name] = el.sourceline or 0
            continue
        b: Bind | None = f.metadata.get("xml")
        if b is None:
            continue
        if b.extras:
            extras_field = f.name
            continue
        if b.path == "." and b.items is not None:
            consumed.update(b.items)
        elif not b.path.startswith("@") and b.path != ".":
            consumed.add(b.head)
        value = _read_bind(b, el, ctx)
        if value is not MISSING:
            kwargs[f.name] = value
    leftovers = [c for c in children(el) if local_name(c) not in consumed]
    if extras_field is not None:
        kwargs[extras_field] = tuple(_read_raw(c, ctx) for c in leftovers)
    else:
        for c in leftovers:
            ctx.warn(f"unknown element <{local_name(c)}> in <{local_name(el)}> ignored", c, once_key=None)
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise ctx.error(str(exc), el) from None


# --------------------------------------------------------------------------- writing


def _get_or_make(parent: etree._Element, segments: list[str], ctx: WriteCtx) -> etree._Element:
    node = parent
    for seg in segments:
        found = children(node, seg)
        node = found[0] if found else ctx.sub(node, seg)
    return node


def _write_bind(b: Bind, el: etree._Element, value: Any, ctx: WriteCtx) -> None:
    if value is None:
        return
    segs = b.path.split("/")
    if b.extras:
        for raw in value:
            _write_raw(ctx.sub(el, raw.tag), raw, ctx)
        return
    if b.items is not None:
        if not value:
            return
        wrapper = el if b.path == "." else _get_or_make(el, segs, ctx)
        for item in value:
            tag, codec = next(((t, c) for t, c in b.items.items() if c.owns(item)), (None, None))
            if tag is None or codec is None:
                raise TypeError(f"no element tag for {type(item).__name__} in <{b.path}>")
            codec.write(ctx.sub(wrapper, tag), item, ctx)
        return
    if segs[-1].startswith("@"):
        holder = _get_or_make(el, segs[:-1], ctx)
        assert isinstance(b.codec, Scalar)
        holder.set(segs[-1][1:], b.codec.format(value))
        return
    if b.path == ".":
        node = el
    else:
        node = _get_or_make(el, segs[:-1], ctx)
        node = ctx.sub(node, segs[-1])
    if isinstance(b.codec, Scalar):
        node.text = b.codec.format(value)
    else:
        assert b.codec is not None
        b.codec.write(node, value, ctx)


def write_struct(obj: Any, el: etree._Element, ctx: WriteCtx) -> None:
    """Write dataclass `obj` into element `el` following its fields' bindings."""
    for f in dataclasses.fields(obj):
        b: Bind | None = f.metadata.get("xml")
        if b is None:
            continue
        value = getattr(obj, f.name)
        if not b.keep and f.default is not MISSING and f.default is not None and value == f.default:
            continue
        _write_bind(b, el, value, ctx)


def _read_ref_item(el: etree._Element, ctx: ReadCtx) -> str:
    ref = (el.get("ref") or "").strip()
    if not ref:
        raise ctx.error("missing required attribute 'ref'", el)
    return ref


REF_ITEM: Node[str] = Custom(_read_ref_item, lambda el, v, ctx: el.set("ref", v), lambda v: isinstance(v, str))
"""List item `<x ref="id"/>` read as the string id."""

TEXT_ITEM: Node[str] = TextNode(STR)
"""List item `<x>text</x>` read as its string."""
