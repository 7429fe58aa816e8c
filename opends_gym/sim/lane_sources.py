"""The ego's road from whatever a task gives: OpenDRIVE lanes, Gen B road segments, the
driver's autopilot waypoints, an ideal track or a traffic car's route.

Why: lateral offset, lane index, SDLP, "off the road" and the rule driver all need the
line the ego's lane follows (curves included) and where the other lanes lie across it.
OpenDS keeps that knowledge in several places depending on the task's version; this
module turns each into one `EgoRoad`: a reference line through the centre of the ego's
start lane, in its driving direction, plus the lane centres across it (+ left).

Sources, first that applies (OpenDS X-band `road/lane`s are handled by `guide.RoadGuide`
itself, they need no line):
1. OpenDRIVE (`openDrive` entry): the driver's start lane (`scenario/driver/openDrive`, or
   the lane under the start pose) followed along the network (`OpenDriveMap.route`); the
   lanes are the car lanes of the start cross-section.
2. Gen B road segments (`road/segments`): the segment the ego starts on or joins, followed
   through the network; its lanes are the declared `leftNeighbor`/`rightNeighbor`
   segments and the segments running parallel to it (2-12 m across, within 25 deg).
3. Gen A 4.x autopilot waypoints of the driver's car (`autoPilot/wayPoints`): the
   follow-box's Catmull-Rom path from the start waypoint. Lanes unknown.
4. The ideal track (`driver/idealTracks`). Lanes unknown.
5. A Gen A traffic car's waypoint path that passes within `JOIN_MAX_M` of the start in the
   ego's direction (the road traffic uses). Lanes unknown.

Where the ego starts off its road's line (the MotorwayTask ego starts on a slip road that
exists only in the scene's 3D model, 89 m from the motorway lane it joins), the line
begins with a cubic Hermite connector from the start pose to a point of the road ahead.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..task.model_task import DrivingTask, Pose
from ..task.values import Rotation
from .opendrive_route import CAR_LANE_TYPES
from .traffic_paths import catmull_rom, polyline
from .traffic_routes import DEFAULT_TENSION, PositionResolver

if TYPE_CHECKING:
    from .road import RoadModel

DEFAULT_LANE_WIDTH_M = 3.5
JOIN_MAX_M = 120.0  # a road further than this from the start is not the ego's
ON_LINE_M = 1.0  # closer than this to the line: no connector
ROUTE_MAX_M = 6000.0
MIN_AHEAD_M = 100.0  # a line that ends sooner than this after the start is not the ego's road  # how far ahead a network route is followed
_SAMPLE_M = 1.0
_PARALLEL_COS = math.cos(math.radians(25.0))


@dataclass(frozen=True)
class EgoRoad:
    """The ego's road: a reference line (x, z), lanes across it (+ left) and its edges."""

    source: str  # opendrive | segments | autopilot | ideal_track | traffic_route
    points: np.ndarray  # (N, 2) world x, z along the driving direction
    lane_laterals_m: tuple[float, ...]  # lane centres across the line, rightmost first
    lane_ids: tuple[str, ...]
    lane_width_m: float
    lanes_known: bool
    left_edge_m: float  # the road's edges across the line (left > 0 > right)
    right_edge_m: float
    join_s_m: float = 0.0  # arc length where the connector from the start pose ends


# --------------------------------------------------------------------------- geometry


def _arc(points: np.ndarray) -> np.ndarray:
    d = np.hypot(np.diff(points[:, 0]), np.diff(points[:, 1]))
    return np.concatenate([[0.0], np.cumsum(d)])


def _dedupe(points: np.ndarray) -> np.ndarray:
    """Drop points that repeat the previous one (a joined route repeats its joints)."""
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.hypot(np.diff(points[:, 0]), np.diff(points[:, 1])) > 1e-6
    return points[keep]


def project(points: np.ndarray, x: float, z: float) -> tuple[float, float, int, float]:
    """(distance from the line, signed offset + left, segment index, arc length) of (x, z)."""
    a = points[:-1]
    d = points[1:] - a
    L2 = np.maximum(d[:, 0] ** 2 + d[:, 1] ** 2, 1e-12)
    t = np.clip(((x - a[:, 0]) * d[:, 0] + (z - a[:, 1]) * d[:, 1]) / L2, 0.0, 1.0)
    px, pz = a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1]
    dist2 = (px - x) ** 2 + (pz - z) ** 2
    k = int(np.argmin(dist2))
    L = math.sqrt(float(L2[k]))
    lx, lz = d[k, 1] / L, -d[k, 0] / L  # left of travel (dx, dz) is (dz, -dx): forward -Z, left -X
    offset = (x - px[k]) * lx + (z - pz[k]) * lz
    s = float(_arc(points[: k + 1])[-1]) + float(t[k]) * L if k else float(t[k]) * L
    return math.sqrt(float(dist2[k])), float(offset), k, s


def heading_of(points: np.ndarray, k: int) -> float:
    """Yaw (0 faces -Z, + turns left) of segment k."""
    dx, dz = points[k + 1] - points[k]
    return math.atan2(-float(dx), -float(dz))


def _hermite(p0: tuple[float, float], yaw0: float, p1: tuple[float, float], yaw1: float) -> np.ndarray:
    """A cubic Hermite curve from p0 (heading yaw0) to p1 (heading yaw1), ~1 m samples."""
    chord = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
    m = 1.2 * chord  # tangent length: a U-turn stays a rounded loop, a lane change an S
    t0 = np.array([-math.sin(yaw0), -math.cos(yaw0)]) * m
    t1 = np.array([-math.sin(yaw1), -math.cos(yaw1)]) * m
    n = max(8, int(math.ceil(2.0 * chord / _SAMPLE_M)))
    u = np.linspace(0.0, 1.0, n + 1)[:, None]
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    out: np.ndarray = h00 * np.asarray(p0) + h10 * t0 + h01 * np.asarray(p1) + h11 * t1
    return out


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _join(start: Pose, line: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The line from the start pose on: the line itself from the start's foot point when the
    start lies on it, else a connector to a point ahead on it. None when too far away."""
    x0, z0 = start.position_m[0], start.position_m[2]
    dist, _, k, s0 = project(line, x0, z0)
    if dist > JOIN_MAX_M:
        return None
    arc = _arc(line)
    if dist <= ON_LINE_M:
        first = max(0, k - 10)  # keep a little of the line behind the start
        return line[first:], 0.0
    along = math.cos(_wrap(heading_of(line, k) - start.yaw_rad))
    advance = 0.5 * (1.0 + along) * max(30.0, 2.0 * dist)  # ahead along the line: none for a U-turn
    sj = min(s0 + advance, float(arc[-1]))
    j = min(int(np.searchsorted(arc, sj, side="right")), len(line) - 1)
    pj = (float(line[j, 0]), float(line[j, 1]))
    yaw_j = heading_of(line, min(j, len(line) - 2))
    conn = _hermite((x0, z0), start.yaw_rad, pj, yaw_j)
    joined = _dedupe(np.vstack([conn, line[j + 1 :]]))
    return joined, float(_arc(conn)[-1])


def _frame(
    source: str,
    points: np.ndarray,
    join_s: float,
    laterals: Sequence[float],
    ids: Sequence[str],
    width: float,
    known: bool,
    edges: tuple[float, float] | None = None,
) -> EgoRoad:
    order = sorted(range(len(laterals)), key=lambda i: laterals[i])
    lats = tuple(float(laterals[i]) for i in order)
    left, right = edges if edges is not None else (lats[-1] + width / 2.0, lats[0] - width / 2.0)
    return EgoRoad(source, points, lats, tuple(ids[i] for i in order), width, known, left, right, join_s)


# --------------------------------------------------------------------------- sources


def _from_opendrive(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    od = road.opendrive
    if od is None:
        return None
    spec = task.scenario.driver.open_drive
    where: tuple[str, int, float] | None
    if spec is not None and spec.start_road_id is not None and spec.start_lane is not None:
        where = (spec.start_road_id, int(spec.start_lane), spec.start_s_m or 0.0)
    else:
        where = od.locate(start.position_m[0], start.position_m[2], CAR_LANE_TYPES)
    if where is None:
        return None
    road_id, lane_id, s = where
    target = (spec.target_road_id, spec.target_lane, spec.target_s_m) if spec is not None else (None, None, None)
    prefs = spec.preferred_connections if spec is not None else ()
    try:
        pts = od.route(road_id, lane_id, s, target[0], target[1], target[2], prefs, max_length_m=ROUTE_MAX_M)
    except ValueError:
        return None
    if len(pts) < 2:
        return None
    joined = _join(start, np.asarray(pts, dtype=float)[:, :2])
    if joined is None:
        return None
    r = od.road(road_id)
    sec = r.sections[od.section_index(r, s, lane_id)]
    edges = od.lane_edges(r, sec, np.array([s]))
    sign = -1.0 if lane_id < 0 else 1.0  # right lanes drive along +s: + t is their left
    t0 = 0.5 * float(edges[lane_id][0][0] + edges[lane_id][1][0])
    lats: list[float] = []
    ids: list[str] = []
    outer: list[float] = []
    for lid, (inner, outer_t) in edges.items():
        lane = sec.lanes[lid]
        if lane.type not in CAR_LANE_TYPES or abs(float(outer_t[0] - inner[0])) < 0.5:
            continue
        c = 0.5 * float(inner[0] + outer_t[0])
        lats.append(-sign * (c - t0))
        ids.append(str(lid))
        outer.extend((-sign * (float(inner[0]) - t0), -sign * (float(outer_t[0]) - t0)))
    width = abs(float(edges[lane_id][1][0] - edges[lane_id][0][0])) or DEFAULT_LANE_WIDTH_M
    return _frame("opendrive", joined[0], joined[1], lats, ids, width, True, (max(outer), min(outer)))


@dataclass
class _Seg:
    id: str
    points: np.ndarray  # (K, 2)
    from_wp: str
    to_wp: str
    jump: bool
    left: str | None
    right: str | None


def _segments(task: DrivingTask) -> list[_Seg]:
    road = task.scenario.road
    if road.segments is None or road.way_points is None:
        return []
    where = PositionResolver(task)
    wps = {w.key: where(w) for w in road.way_points.points}
    out = []
    for seg in road.segments.items:
        chain = [seg.from_wp, *seg.via, seg.to_wp]
        xyz = [wps.get(w) for w in chain]
        if any(p is None for p in xyz):
            continue
        ctrl = np.array(xyz, dtype=float)
        if seg.via:
            pts, _ = catmull_rom(ctrl, seg.curve_tension if seg.curve_tension is not None else DEFAULT_TENSION, False)
        else:
            pts, _ = polyline(ctrl)
        pts2 = _dedupe(pts[:, [0, 2]])
        if len(pts2) >= 2:
            out.append(_Seg(seg.id, pts2, seg.from_wp, seg.to_wp, seg.jump, seg.left_neighbor, seg.right_neighbor))
    return out


def _best_match(start: Pose, lines: Sequence[np.ndarray], min_ahead_m: float = MIN_AHEAD_M) -> tuple[int, float] | None:
    """The line the start pose belongs to: near, heading its way and not ending at once
    (cost in metres)."""
    x0, z0 = start.position_m[0], start.position_m[2]
    best: tuple[float, int] | None = None
    for i, line in enumerate(lines):
        dist, _, k, s = project(line, x0, z0)
        if dist > JOIN_MAX_M or float(_arc(line)[-1]) - s < min_ahead_m:
            continue
        along = math.cos(_wrap(heading_of(line, k) - start.yaw_rad))
        cost = dist + (20.0 * (1.0 - along) if dist > ON_LINE_M else 40.0 * (1.0 - along))
        if best is None or cost < best[0] - 1e-9:
            best = (cost, i)
    return None if best is None else (best[1], best[0])


def _chain(segs: list[_Seg], first: int) -> np.ndarray:
    """Points from segment `first` on, through the network (straightest continuation, jumps
    end it), up to ROUTE_MAX_M."""
    outgoing: dict[str, list[int]] = {}
    for i, g in enumerate(segs):
        if not g.jump:
            outgoing.setdefault(g.from_wp, []).append(i)
    parts = [segs[first].points]
    length = float(_arc(segs[first].points)[-1])
    cur = first
    while length < ROUTE_MAX_M:
        nxt = outgoing.get(segs[cur].to_wp, [])
        if not nxt:
            break
        here = heading_of(segs[cur].points, len(segs[cur].points) - 2)
        cur = min(nxt, key=lambda i: abs(_wrap(heading_of(segs[i].points, 0) - here)))
        parts.append(segs[cur].points[1:])
        length += float(_arc(segs[cur].points)[-1])
    return _dedupe(np.vstack(parts))


def _across(line: np.ndarray, s: float, others: Sequence[np.ndarray]) -> list[float]:
    """Lateral offsets (+ left) of the other lines that run parallel to `line` at arc length s."""
    arc = _arc(line)
    k = min(max(int(np.searchsorted(arc, s, side="right")) - 1, 0), len(line) - 2)
    f = (s - arc[k]) / max(arc[k + 1] - arc[k], 1e-9)
    px, pz = line[k] + f * (line[k + 1] - line[k])
    yaw = heading_of(line, k)
    out = []
    for o in others:
        dist, _, j, _ = project(o, float(px), float(pz))
        if not (1.5 <= dist <= 12.0) or abs(math.cos(_wrap(heading_of(o, j) - yaw))) < _PARALLEL_COS:
            continue
        _, off, _, _ = project(line, *map(float, _foot(o, float(px), float(pz))))
        out.append(off)
    return out


def _foot(line: np.ndarray, x: float, z: float) -> tuple[float, float]:
    a = line[:-1]
    d = line[1:] - a
    L2 = np.maximum(d[:, 0] ** 2 + d[:, 1] ** 2, 1e-12)
    t = np.clip(((x - a[:, 0]) * d[:, 0] + (z - a[:, 1]) * d[:, 1]) / L2, 0.0, 1.0)
    px, pz = a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1]
    k = int(np.argmin((px - x) ** 2 + (pz - z) ** 2))
    return float(px[k]), float(pz[k])


def _lanes(offsets: list[float]) -> tuple[list[float], float]:
    """Lane centres (the reference's own at 0) and their width, offsets merged within 1 m."""
    lats = [0.0]
    for off in sorted(offsets, key=abs):
        if all(abs(off - c) > 1.0 for c in lats):
            lats.append(off)
    lats.sort()
    gaps = [b - a for a, b in itertools.pairwise(lats)]
    width = min(gaps) if gaps else DEFAULT_LANE_WIDTH_M
    return lats, min(max(width, 2.5), 5.0)


def _neighbours(by_id: dict[str, _Seg], first: str) -> list[str]:
    """Every segment reached through declared leftNeighbor/rightNeighbor links (a three-lane
    road declares its outer lanes on the middle one only, or chains them)."""
    seen, todo = {first}, [first]
    while todo:
        g = by_id[todo.pop()]
        for n in (g.left, g.right):
            for name in (n or "").split(","):
                name = name.strip()
                if name and name in by_id and name not in seen:
                    seen.add(name)
                    todo.append(name)
    seen.discard(first)
    return sorted(seen)


def _along(segs: list[_Seg], names: list[str]) -> list[str]:
    """The named segments and every segment chained to them before or after (a neighbour
    lane goes on beyond the one segment that declares it)."""
    before: dict[str, list[str]] = {}
    after: dict[str, list[str]] = {}
    for g in segs:
        if not g.jump:
            after.setdefault(g.from_wp, []).append(g.id)
            before.setdefault(g.to_wp, []).append(g.id)
    by_id = {g.id: g for g in segs}
    seen, todo = set(names), list(names)
    while todo:
        g = by_id[todo.pop()]
        for n in (*after.get(g.to_wp, ()), *before.get(g.from_wp, ())):
            if n not in seen:
                seen.add(n)
                todo.append(n)
    return sorted(seen)


def _from_segments(task: DrivingTask, start: Pose) -> EgoRoad | None:
    segs = _segments(task)
    if not segs:
        return None
    found = _best_match(start, [g.points for g in segs if not g.jump], 0.0)
    if found is None:
        return None
    usable = [i for i, g in enumerate(segs) if not g.jump]
    first = usable[found[0]]
    joined = _join(start, _chain(segs, first))
    if joined is None:
        return None
    points, join_s = joined
    by_id = {g.id: g for g in segs}
    declared = [by_id[n].points for n in _along(segs, _neighbours(by_id, segs[first].id))]
    others = declared or [g.points for i, g in enumerate(segs) if i != first and not g.jump]
    arc = _arc(points)
    probe = min(join_s + 1.0, float(arc[-1]))
    lats, width = _lanes(_across(points, probe, others))
    ids = [f"{segs[first].id}{'' if abs(c) < 1e-9 else f'{c:+.1f}m'}" for c in lats]
    return _frame("segments", points, join_s, lats, ids, width, True)


def _single(source: str, start: Pose, line: np.ndarray, width: float = DEFAULT_LANE_WIDTH_M) -> EgoRoad | None:
    joined = _join(start, line)
    if joined is None:
        return None
    return _frame(source, joined[0], joined[1], [0.0], ["0"], DEFAULT_LANE_WIDTH_M, False, (width, -width))


def _from_autopilot(task: DrivingTask, start: Pose) -> EgoRoad | None:
    ap = task.scenario.driver.car.auto_pilot
    if ap is None or len(ap.way_points) < 2:
        return None
    where = PositionResolver(task)
    xyz = [where(w) for w in ap.way_points]
    if any(p is None for p in xyz):
        return None
    ids = [w.id for w in ap.way_points]
    k = ids.index(ap.start_way_point) if ap.start_way_point in ids else 0
    ctrl = np.array(xyz, dtype=float)
    tension = ap.curve_tension if ap.curve_tension is not None else DEFAULT_TENSION
    pts, knots = catmull_rom(ctrl, tension, bool(ap.path_is_cycle))
    line = pts[knots[k] :, [0, 2]]
    if ap.path_is_cycle:  # go round once more from the start waypoint
        line = np.vstack([line, pts[1 : knots[k] + 1, [0, 2]]])
    line = _dedupe(line)
    return _single("autopilot", start, line) if len(line) >= 2 else None


def _from_ideal_track(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    """The ideal track, continued on the traffic route that carries on from its end (the
    track is the analyzer's stretch, the road goes on)."""
    if not road.ideal_tracks:
        return None
    line, width = next(iter(road.ideal_tracks.values()))
    pts = _dedupe(np.asarray(line.xz, dtype=float))
    if len(pts) < 2:
        return None
    end = Pose((float(pts[-1, 0]), 0.0, float(pts[-1, 1])), Rotation.from_euler_deg(0.0, math.degrees(heading_of(pts, len(pts) - 2)), 0.0))
    lines = _traffic_lines(task)
    found = _best_match(end, lines)
    if found is not None and found[1] <= 10.0:
        _, _, k, _ = project(lines[found[0]], float(pts[-1, 0]), float(pts[-1, 1]))
        pts = _dedupe(np.vstack([pts, lines[found[0]][k + 1 :]]))
    return _single("ideal_track", start, pts, max(width / 2.0, DEFAULT_LANE_WIDTH_M))


def _traffic_lines(task: DrivingTask) -> list[np.ndarray]:
    """The Gen A waypoint paths of the traffic cars, as (x, z) lines."""
    where = PositionResolver(task)
    lines = []
    for v in task.scenario.vehicles:
        wps = v.way_points
        if len(wps) < 2:
            continue
        xyz = [where(w) for w in wps]
        if any(p is None for p in xyz):
            continue
        tension = v.curve_tension if v.curve_tension is not None else DEFAULT_TENSION
        pts, _ = catmull_rom(np.array(xyz, dtype=float), tension, bool(v.path_is_cycle))
        line = _dedupe(pts[:, [0, 2]])
        if len(line) >= 2:
            lines.append(line)
    return lines


def _from_traffic(task: DrivingTask, start: Pose) -> EgoRoad | None:
    lines = _traffic_lines(task)
    found = _best_match(start, lines)
    return _single("traffic_route", start, lines[found[0]]) if found is not None else None


def ego_road(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    """The ego's road from the first source that applies (module docstring), or None."""
    return (
        _from_opendrive(task, road, start)
        or _from_segments(task, start)
        or _from_autopilot(task, start)
        or _from_ideal_track(task, road, start)
        or _from_traffic(task, start)
    )
