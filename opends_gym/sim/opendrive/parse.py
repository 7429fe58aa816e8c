"""Reading `.xodr` files (OpenDRIVE 1.4-1.6) into plain road, lane and junction records.

Why: OpenDS 2023 tasks place the driver, traffic and triggers on OpenDRIVE roads. This
module only reads and checks the file; geometry lives in `opendrive_geometry.py` and the
queries (locate, lane centres, routes) in `opendrive.py`. The file is parsed with the same
safe lxml settings as the task files (no entities, no DTD, no network). A malformed or
inconsistent file raises `OpenDriveError` naming file, line and element; dangling links
(a successor road or junction that does not exist) are logged as warnings and dropped.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from ...task.bind import INT, shown
from ...task.errors import TaskError
from ...task.xmlsafe import local_name, parse_file
from .geometry import Arc, Cubic, Geometry, Line, ParamPoly3, Poly3, ReferenceLine, Spiral

log = logging.getLogger("opends_gym.opendrive")

# The map samples each reference line every metre (map._SAMPLE_M), so a road of length 1e12
# would never finish loading. The caps are far above OpenDS's own maps (init_drive: 2 roads,
# 2.6 km); a network at the cap (4 roads of 50 km) loads in 0.8 s and 100 MB on this project's
# CI host.
MAX_ROAD_LENGTH_M = 50_000.0
MAX_NETWORK_LENGTH_M = 200_000.0


class OpenDriveError(TaskError):
    """An OpenDRIVE file that cannot be used; the message names file, line and element."""


@dataclass(frozen=True)
class Lane:
    id: int
    type: str
    width: Cubic  # ds from the lane section's start
    border: Cubic  # used when the lane gives <border> instead of <width>
    predecessor: int | None = None
    successor: int | None = None


@dataclass(frozen=True)
class LaneSection:
    s0: float
    s1: float
    left: tuple[Lane, ...]  # ordered 1, 2, 3 ... (outwards)
    right: tuple[Lane, ...]  # ordered -1, -2, -3 ... (outwards)
    lanes: dict[int, Lane] = field(compare=False)


@dataclass(frozen=True)
class RoadLink:
    element_type: str  # road | junction
    element_id: str
    contact_point: str | None  # start | end (roads only)


@dataclass
class Road:
    id: str
    name: str
    length: float
    junction: str  # "-1" when the road is not a connecting road of a junction
    reference: ReferenceLine
    lane_offset: Cubic
    elevation: Cubic
    sections: list[LaneSection]
    predecessor: RoadLink | None = None
    successor: RoadLink | None = None
    line: int = 0


@dataclass(frozen=True)
class Connection:
    id: str
    incoming_road: str
    connecting_road: str
    contact_point: str  # where the connecting road is entered: start | end
    lane_links: tuple[tuple[int, int], ...]  # (from lane on the incoming road, to lane on the connecting road)


@dataclass(frozen=True)
class Junction:
    id: str
    connections: tuple[Connection, ...]


@dataclass
class ParsedOpenDrive:
    path: Path
    roads: dict[str, Road]
    junctions: dict[str, Junction]
    warnings: list[str] = field(default_factory=list)


class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.warnings: list[str] = []

    def error(self, message: str, el: etree._Element | None) -> OpenDriveError:
        return OpenDriveError(message, self.path, el.sourceline if el is not None else None, local_name(el) if el is not None else None)

    def warn(self, message: str, el: etree._Element | None) -> None:
        where = f"{self.path}:{el.sourceline} <{local_name(el)}>" if el is not None else str(self.path)
        text = f"{where}: {message}"
        self.warnings.append(text)
        log.warning("%s", text)

    def num(self, el: etree._Element, name: str, default: float | None = None) -> float:
        raw = el.get(name)
        if raw is None or not raw.strip():
            if default is None:
                raise self.error(f"attribute '{name}' is required", el)
            return default
        try:
            value = float(raw)
        except ValueError:
            raise self.error(f"attribute '{name}'='{shown(raw)}' is not a number", el) from None
        if not math.isfinite(value):
            raise self.error(f"attribute '{name}'='{shown(raw)}' is not finite", el)
        return value

    def int_(self, el: etree._Element, name: str) -> int:
        """An integer attribute in Java `int` range (OpenDS reads ids with `Integer.parseInt`)."""
        raw = (el.get(name) or "").strip()
        try:
            value = INT.parse(raw)
        except (ValueError, OverflowError):
            raise self.error(f"attribute '{name}'='{shown(raw)}' is not an integer", el) from None
        return value

    def text(self, el: etree._Element, name: str) -> str:
        raw = (el.get(name) or "").strip()
        if not raw:
            raise self.error(f"attribute '{name}' is required", el)
        return raw

    def cubic(self, parent: etree._Element | None, tag: str, start: str) -> Cubic:
        if parent is None:
            return Cubic()
        recs = [
            (self.num(e, start, 0.0), self.num(e, "a", 0.0), self.num(e, "b", 0.0), self.num(e, "c", 0.0), self.num(e, "d", 0.0))
            for e in _children(parent, tag)
        ]
        return Cubic.from_records(recs)


def _children(el: etree._Element, tag: str) -> list[etree._Element]:
    return [c for c in el if isinstance(c.tag, str) and local_name(c) == tag]


def _child(el: etree._Element, tag: str) -> etree._Element | None:
    found = _children(el, tag)
    return found[0] if found else None


def parse_opendrive(path: str | Path) -> ParsedOpenDrive:
    """Read an .xodr file. Raises OpenDriveError (file, line, element) when it is unusable."""
    path = Path(path)
    try:
        root = parse_file(path)
    except OpenDriveError:
        raise
    except TaskError as e:
        raise OpenDriveError(e.reason, e.file, e.line, e.element) from e
    r = _Reader(path)
    if local_name(root) != "OpenDRIVE":
        raise r.error(f"the root element is <{local_name(root)}>, not <OpenDRIVE>", root)
    roads: dict[str, Road] = {}
    for el in _children(root, "road"):
        road = _read_road(r, el)
        if road.id in roads:
            raise r.error(f"road id '{road.id}' is used twice (first at line {roads[road.id].line})", el)
        roads[road.id] = road
    if not roads:
        raise r.error("the file has no <road>", root)
    total = sum(road.length for road in roads.values())
    if total > MAX_NETWORK_LENGTH_M:
        raise r.error(f"the roads add up to {total:g} m; the cap is {MAX_NETWORK_LENGTH_M:g} m (the map samples every metre)", root)
    junctions: dict[str, Junction] = {}
    for el in _children(root, "junction"):
        j = _read_junction(r, el, roads)
        if j.id in junctions:
            raise r.error(f"junction id '{j.id}' is used twice", el)
        junctions[j.id] = j
    for road in roads.values():
        for which in ("predecessor", "successor"):
            link = getattr(road, which)
            if link is None:
                continue
            known = roads if link.element_type == "road" else junctions
            if link.element_id not in known:
                r.warn(f"road '{road.id}' {which} names {link.element_type} '{link.element_id}', which does not exist; link ignored", None)
                setattr(road, which, None)
    return ParsedOpenDrive(path, roads, junctions, r.warnings)


def _read_road(r: _Reader, el: etree._Element) -> Road:
    rid = r.text(el, "id")
    plan = _child(el, "planView")
    if plan is None:
        raise r.error(f"road '{rid}' has no <planView>", el)
    geoms = [g for g in (_read_geometry(r, g) for g in _children(plan, "geometry")) if g is not None]
    if not geoms:
        raise r.error(f"road '{rid}' has no usable <geometry>", plan)
    length = r.num(el, "length", sum(g.length for g in geoms))
    if length <= 0.0:
        raise r.error(f"road '{rid}' has length {length}; it must be positive", el)
    if length > MAX_ROAD_LENGTH_M:
        raise r.error(f"road '{rid}' has length {length:g} m; the cap is {MAX_ROAD_LENGTH_M:g} m (the map samples every metre)", el)
    lanes_el = _child(el, "lanes")
    if lanes_el is None:
        raise r.error(f"road '{rid}' has no <lanes>", el)
    section_els = _children(lanes_el, "laneSection")
    if not section_els:
        raise r.error(f"road '{rid}' has no <laneSection>", lanes_el)
    starts = [r.num(s, "s", 0.0) for s in section_els]
    order = sorted(range(len(starts)), key=lambda i: starts[i])
    sections = []
    for k, i in enumerate(order):
        s1 = starts[order[k + 1]] if k + 1 < len(order) else length
        sections.append(_read_section(r, section_els[i], starts[i], s1))
    pred = succ = None
    link = _child(el, "link")
    if link is not None:
        p, s = _child(link, "predecessor"), _child(link, "successor")
        pred = _read_road_link(r, p) if p is not None else None
        succ = _read_road_link(r, s) if s is not None else None
    elevation = _child(el, "elevationProfile")
    return Road(
        id=rid,
        name=el.get("name", ""),
        length=length,
        junction=(el.get("junction") or "-1").strip(),
        reference=ReferenceLine(geoms),
        lane_offset=r.cubic(lanes_el, "laneOffset", "s"),
        elevation=r.cubic(elevation, "elevation", "s"),
        sections=sections,
        predecessor=pred,
        successor=succ,
        line=el.sourceline or 0,
    )


def _read_geometry(r: _Reader, el: etree._Element) -> Geometry | None:
    s0, x0, y0, hdg, length = (r.num(el, n) for n in ("s", "x", "y", "hdg", "length"))
    if length < 0.0:
        raise r.error(f"geometry length {length} is negative", el)
    if length == 0.0:
        r.warn("zero-length geometry skipped", el)
        return None
    shapes = [c for c in el if isinstance(c.tag, str)]
    if len(shapes) != 1:
        raise r.error("a <geometry> needs exactly one of line, arc, spiral, poly3, paramPoly3", el)
    shape = shapes[0]
    kind = local_name(shape)
    if kind == "line":
        return Line(s0, x0, y0, hdg, length)
    if kind == "arc":
        return Arc(s0, x0, y0, hdg, length, r.num(shape, "curvature"))
    if kind == "spiral":
        return Spiral(s0, x0, y0, hdg, length, r.num(shape, "curvStart"), r.num(shape, "curvEnd"))
    if kind == "poly3":
        return Poly3(s0, x0, y0, hdg, length, (r.num(shape, "a"), r.num(shape, "b"), r.num(shape, "c"), r.num(shape, "d")))
    if kind == "paramPoly3":
        p_range = (shape.get("pRange") or "normalized").strip()
        if p_range not in ("normalized", "arcLength"):
            raise r.error(f"pRange '{p_range}' must be 'normalized' or 'arcLength'", shape)
        u = (r.num(shape, "aU"), r.num(shape, "bU"), r.num(shape, "cU"), r.num(shape, "dU"))
        v = (r.num(shape, "aV"), r.num(shape, "bV"), r.num(shape, "cV"), r.num(shape, "dV"))
        return ParamPoly3(s0, x0, y0, hdg, length, u, v, normalized=p_range == "normalized")
    raise r.error(f"unknown geometry type <{kind}>", shape)


def _read_section(r: _Reader, el: etree._Element, s0: float, s1: float) -> LaneSection:
    lanes: dict[int, Lane] = {}
    left: list[Lane] = []
    right: list[Lane] = []
    for side, sign in (("left", 1), ("right", -1)):
        side_el = _child(el, side)
        if side_el is None:
            continue
        for lane_el in _children(side_el, "lane"):
            lane = _read_lane(r, lane_el)
            if lane.id == 0 or (lane.id > 0) != (sign > 0):
                raise r.error(f"lane id {lane.id} does not belong in <{side}> (left lanes are positive, right lanes negative)", lane_el)
            if lane.id in lanes:
                raise r.error(f"lane id {lane.id} is used twice in this laneSection", lane_el)
            lanes[lane.id] = lane
            (left if sign > 0 else right).append(lane)
    left.sort(key=lambda ln: ln.id)
    right.sort(key=lambda ln: -ln.id)
    for side_lanes in (left, right):
        for k, lane in enumerate(side_lanes, start=1):
            if abs(lane.id) != k:
                raise r.error(f"lane ids on one side must be consecutive from 1; lane {lane.id} has no inner neighbour", el)
    return LaneSection(s0, s1, tuple(left), tuple(right), lanes)


def _read_lane(r: _Reader, el: etree._Element) -> Lane:
    lid = r.int_(el, "id")
    pred = succ = None
    link = _child(el, "link")
    if link is not None:
        p, s = _child(link, "predecessor"), _child(link, "successor")
        pred = r.int_(p, "id") if p is not None else None
        succ = r.int_(s, "id") if s is not None else None
    width = r.cubic(el, "width", "sOffset")
    border = r.cubic(el, "border", "sOffset")
    if width.empty and border.empty:
        r.warn(f"lane {lid} has neither <width> nor <border>; width 0", el)
    return Lane(lid, (el.get("type") or "none").strip(), width, border, pred, succ)


def _read_road_link(r: _Reader, el: etree._Element) -> RoadLink:
    kind = (el.get("elementType") or "road").strip()
    if kind not in ("road", "junction"):
        raise r.error(f"elementType '{kind}' must be 'road' or 'junction'", el)
    cp = (el.get("contactPoint") or "").strip() or None
    if cp not in (None, "start", "end"):
        raise r.error(f"contactPoint '{cp}' must be 'start' or 'end'", el)
    return RoadLink(kind, r.text(el, "elementId"), cp)


def _read_junction(r: _Reader, el: etree._Element, roads: dict[str, Road]) -> Junction:
    jid = r.text(el, "id")
    conns = []
    for c in _children(el, "connection"):
        cid = r.text(c, "id")
        incoming, connecting = r.text(c, "incomingRoad"), r.text(c, "connectingRoad")
        cp = (c.get("contactPoint") or "start").strip()
        if cp not in ("start", "end"):
            raise r.error(f"contactPoint '{cp}' must be 'start' or 'end'", c)
        missing = [n for n in (incoming, connecting) if n not in roads]
        if missing:
            r.warn(f"junction '{jid}' connection '{cid}' names road '{missing[0]}', which does not exist; connection ignored", c)
            continue
        links = tuple((r.int_(ll, "from"), r.int_(ll, "to")) for ll in _children(c, "laneLink"))
        conns.append(Connection(cid, incoming, connecting, cp, links))
    return Junction(jid, tuple(conns))
