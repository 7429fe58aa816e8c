"""Gen B road segments as the ego's road: the segment it starts on or joins, followed
through the network, and the lanes beside it.

Why: a Gen B task (OpenDS-CTS and later) describes its roads only as the directed segments
traffic drives on; each segment is one lane. The lanes beside the ego's are the segments
its `leftNeighbor`/`rightNeighbor` links name (followed along their chains), or, where no
links are declared, the segments running parallel to it (1.5-12 m across, within 25 deg).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..task.model_task import DrivingTask, Pose
from .route_line import arc_lengths, best_match, dedupe, foot_point, heading_of, join_start, project, wrap
from .traffic.paths import catmull_rom, polyline
from .traffic.routes import DEFAULT_TENSION, PositionResolver

DEFAULT_LANE_WIDTH_M = 3.5
ROUTE_MAX_M = 6000.0  # how far ahead a network route is followed
_PARALLEL_COS = math.cos(math.radians(25.0))


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
        pts2 = dedupe(pts[:, [0, 2]])
        if len(pts2) >= 2:
            out.append(_Seg(seg.id, pts2, seg.from_wp, seg.to_wp, seg.jump, seg.left_neighbor, seg.right_neighbor))
    return out


def _chain(segs: list[_Seg], first: int) -> np.ndarray:
    """Points from segment `first` on, through the network (straightest continuation, jumps
    end it), up to ROUTE_MAX_M."""
    outgoing: dict[str, list[int]] = {}
    for i, g in enumerate(segs):
        if not g.jump:
            outgoing.setdefault(g.from_wp, []).append(i)
    parts = [segs[first].points]
    length = float(arc_lengths(segs[first].points)[-1])
    cur = first
    while length < ROUTE_MAX_M:
        nxt = outgoing.get(segs[cur].to_wp, [])
        if not nxt:
            break
        here = heading_of(segs[cur].points, len(segs[cur].points) - 2)
        cur = min(nxt, key=lambda i: abs(wrap(heading_of(segs[i].points, 0) - here)))
        parts.append(segs[cur].points[1:])
        length += float(arc_lengths(segs[cur].points)[-1])
    return dedupe(np.vstack(parts))


def _across(line: np.ndarray, s: float, others: Sequence[np.ndarray]) -> list[float]:
    """Lateral offsets (+ left) of the other lines that run parallel to `line` at arc length s."""
    arc = arc_lengths(line)
    k = min(max(int(np.searchsorted(arc, s, side="right")) - 1, 0), len(line) - 2)
    f = (s - arc[k]) / max(arc[k + 1] - arc[k], 1e-9)
    px, pz = line[k] + f * (line[k + 1] - line[k])
    yaw = heading_of(line, k)
    out = []
    for o in others:
        dist, _, j, _ = project(o, float(px), float(pz))
        if not (1.5 <= dist <= 12.0) or abs(math.cos(wrap(heading_of(o, j) - yaw))) < _PARALLEL_COS:
            continue
        _, off, _, _ = project(line, *map(float, foot_point(o, float(px), float(pz))))
        out.append(off)
    return out


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


def segment_road(task: DrivingTask, start: Pose) -> tuple[np.ndarray, float, list[float], list[str], float] | None:
    """(line, connector length, lane centres across it, lane ids, lane width) of the segment
    road the ego starts on or joins, or None."""
    segs = _segments(task)
    if not segs:
        return None
    found = best_match(start, [g.points for g in segs if not g.jump], 0.0)
    if found is None:
        return None
    usable = [i for i, g in enumerate(segs) if not g.jump]
    first = usable[found[0]]
    joined = join_start(start, _chain(segs, first))
    if joined is None:
        return None
    points, join_s = joined
    by_id = {g.id: g for g in segs}
    declared = [by_id[n].points for n in _along(segs, _neighbours(by_id, segs[first].id))]
    others = declared or [g.points for i, g in enumerate(segs) if i != first and not g.jump]
    arc = arc_lengths(points)
    probe = min(join_s + 1.0, float(arc[-1]))
    lats, width = _lanes(_across(points, probe, others))
    ids = [f"{segs[first].id}{'' if abs(c) < 1e-9 else f'{c:+.1f}m'}" for c in lats]
    return points, join_s, lats, ids, width
