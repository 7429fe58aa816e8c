"""Where traffic may go: per-object waypoint paths (Gen A) and the road network (Gen B).

Why: the traffic manager moves every object along a path id; this module turns the task's
waypoints and segments into those paths once, and answers the rare questions asked when an
object reaches the end of a leg (which waypoint is this, what does it ask for, which
segment comes next).

OpenDS facts kept here: a Gen A path is one Catmull-Rom spline through a vehicle's own
waypoints (closed when `pathIsCycle`); each waypoint's speed applies from that waypoint
on. A Gen B segment is a straight line from `from` to `to`, or a Catmull-Rom spline when
it has `via` waypoints. At a segment's end the next one is drawn among the segments that
start there, weighted by `probability`, unless one of them is in the object's own
`segments` list (those are *preferred*, not exclusive). A waypoint with no outgoing
segment is an end point: the object stops there for good.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ...task.model_road import RoadWayPoint
from ...task.model_scene import Point
from ...task.model_task import DrivingTask
from ...task.model_traffic import Pedestrian, TrafficVehicle, VehicleWayPoint
from .paths import PathBank, catmull_rom, polyline
from .state import N_COLUMNS, NEXT_DRAWN

log = logging.getLogger(__name__)

TURN_CODES = {"off": 0, "left": 1, "right": 2, "both": 3}
DEFAULT_TENSION = 0.05
DEFAULT_SPEED_MPS = 50.0 / 3.6


@dataclass(frozen=True)
class WaypointInfo:
    """What a waypoint asks of the objects passing it (None = leave as it is)."""

    id: str
    xyz: tuple[float, float, float]
    light: str | None = None
    head_light: float | None = None
    turn_signal: int | None = None
    brake_light: bool | None = None
    waiting_s: float = 0.0


@dataclass(frozen=True)
class OwnPath:
    """Gen A: one object's own spline. wp_s has one entry per leg end (cyclic: n+1)."""

    path: int
    wps: tuple[WaypointInfo, ...]
    wp_s: np.ndarray
    speed: np.ndarray
    cyclic: bool
    start: int

    def index(self, wp_id: str) -> int | None:
        return next((k for k, w in enumerate(self.wps) if w.id == wp_id), None)

    @property
    def legs(self) -> int:
        return len(self.wps) if self.cyclic else len(self.wps) - 1


@dataclass(frozen=True)
class NetSegment:
    index: int
    id: str
    path: int
    length: float
    from_wp: str
    to_wp: str
    speed: float
    jump: bool
    probability: float
    left: int = -1
    right: int = -1
    give_way: tuple[int, ...] = ()
    via_s: dict[str, float] = field(default_factory=dict)


class PositionResolver:
    """Waypoint positions: inline translation, else a scene point, else a scene model."""

    def __init__(self, task: DrivingTask) -> None:
        self.points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}
        self.models = {m.id: m.translation_m for m in task.scene.models if m.translation_m is not None}

    def __call__(self, wp: VehicleWayPoint | RoadWayPoint) -> tuple[float, float, float] | None:
        if wp.translation_m is not None:
            return wp.translation_m
        return self.points.get(wp.ref) or self.models.get(wp.ref)


def _info(wp: VehicleWayPoint | RoadWayPoint, key: str, xyz: tuple[float, float, float]) -> WaypointInfo:
    return WaypointInfo(
        id=key,
        xyz=(float(xyz[0]), float(xyz[1]), float(xyz[2])),
        light=wp.traffic_light or None,
        head_light=wp.head_light_intensity,
        turn_signal=TURN_CODES.get(wp.turn_signal) if wp.turn_signal else None,
        brake_light=wp.brake_light_on,
        waiting_s=max(0.0, wp.waiting_time_s or 0.0),
    )


def build_own_path(obj: TrafficVehicle | Pedestrian, paths: PathBank, where: PositionResolver) -> OwnPath:
    """Gen A: the object's spline through its own waypoints. Raises ValueError when unusable."""
    wps: list[WaypointInfo] = []
    speeds: list[float] = []
    last = DEFAULT_SPEED_MPS if isinstance(obj, TrafficVehicle) else 5.0 / 3.6
    for k, wp in enumerate(obj.way_points):
        xyz = where(wp)
        if xyz is None:
            raise ValueError(f"waypoint '{wp.id or wp.ref}' (line {wp.line}) has no position")
        wps.append(_info(wp, wp.id or wp.ref or f"#{k}", xyz))
        last = wp.speed_mps if wp.speed_mps is not None else last
        speeds.append(max(0.0, float(last)))
    if len(wps) < 2:
        raise ValueError("a waypoint path needs at least two waypoints")
    cyclic = bool(obj.path_is_cycle)
    tension = obj.curve_tension if obj.curve_tension is not None else DEFAULT_TENSION
    pts, knots = catmull_rom(np.array([w.xyz for w in wps]), tension, cyclic)
    pid = paths.add(pts)
    s = paths.arc_lengths(pid)[knots]
    start = 0
    if obj.start_way_point:
        found = next((k for k, w in enumerate(wps) if w.id == obj.start_way_point), None)
        if found is None:
            raise ValueError(f"start waypoint '{obj.start_way_point}' is not one of its waypoints")
        start = found
    if not cyclic and start == len(wps) - 1:
        start = 0  # the end of an open path restarts at its first waypoint
    return OwnPath(pid, tuple(wps), s, np.asarray(speeds), cyclic, start)


class RoadNetwork:
    """Gen B: road waypoints and directed segments, each segment a path of the bank."""

    def __init__(self, task: DrivingTask, paths: PathBank, where: PositionResolver) -> None:
        road = task.scenario.road
        self.waypoints: dict[str, WaypointInfo] = {}
        for wp in road.way_points.points if road.way_points else ():
            xyz = where(wp)
            if xyz is None:
                log.warning("road waypoint '%s' (line %s) has no position; ignored", wp.key, wp.line)
                continue
            self.waypoints[wp.key] = _info(wp, wp.key, xyz)
        self.right_hand = not (road.segments is not None and road.segments.is_right_hand_traffic is False)
        items = road.segments.items if road.segments else ()
        self.segments: list[NetSegment] = []
        self.by_id: dict[str, int] = {}
        self.outgoing: dict[str, list[int]] = {}
        self.parents: dict[str, list[int]] = {}
        pending = []
        for seg in items:
            chain = [seg.from_wp, *seg.via, seg.to_wp]
            if any(w not in self.waypoints for w in chain):
                log.warning("segment '%s' (line %s) names an unknown waypoint; ignored", seg.id, seg.line)
                continue
            ctrl = np.array([self.waypoints[w].xyz for w in chain])
            if seg.via:
                pts, knots = catmull_rom(ctrl, seg.curve_tension if seg.curve_tension is not None else DEFAULT_TENSION, False)
            else:
                pts, knots = polyline(ctrl)
            pid = paths.add(pts)
            s = paths.arc_lengths(pid)
            k = len(self.segments)
            self.by_id[seg.id] = k
            self.segments.append(
                NetSegment(
                    k,
                    seg.id,
                    pid,
                    float(s[-1]),
                    seg.from_wp,
                    seg.to_wp,
                    max(0.0, seg.speed_mps),
                    seg.jump,
                    max(0.0, seg.probability),
                    via_s={w: float(s[knots[j + 1]]) for j, w in enumerate(seg.via)},
                )
            )
            pending.append(seg)
            self.outgoing.setdefault(seg.from_wp, []).append(k)
            for w in seg.via:
                self.parents.setdefault(w, []).append(k)
        for k, seg in enumerate(pending):  # neighbours and priorities, now that every id is known
            names = [n.strip() for n in (seg.give_way_to or "").split(",") if n.strip()]
            old = self.segments[k]
            self.segments[k] = NetSegment(
                **{
                    **old.__dict__,
                    "left": self.by_id.get(seg.left_neighbor or "", -1),
                    "right": self.by_id.get(seg.right_neighbor or "", -1),
                    "give_way": tuple(self.by_id[n] for n in names if n in self.by_id),
                }
            )

    def preferred(self, refs: tuple[str, ...]) -> frozenset[int]:
        return frozenset(self.by_id[r] for r in refs if r in self.by_id)

    def continuations(self, has_light: Callable[[str], bool]) -> np.ndarray:
        """One row per segment (columns `traffic.motion.N_*`): what a car that leaves no choice
        to chance does on entering it, so a compiled kernel can move cars on without Python
        (`traffic.motion.continue_on_network`). A segment is enterable that way unless it is a
        jump, its end waypoint has a traffic light (`has_light`, the car queues for it) or more
        than one segment leaves it (the next one is drawn with the world's rng)."""
        out = np.zeros((max(1, len(self.segments)), N_COLUMNS))
        for k, seg in enumerate(self.segments):
            to, start = self.waypoints[seg.to_wp], self.waypoints[seg.from_wp]
            leaving = self.outgoing.get(seg.to_wp) or []
            nxt = leaving[0] if len(leaving) == 1 else -1 if not leaving else NEXT_DRAWN
            v_next = 0.0 if nxt < 0 else seg.speed if self.segments[nxt].jump else self.segments[nxt].speed
            quiet = not seg.jump and nxt != NEXT_DRAWN and not (to.light is not None and has_light(to.light))
            out[k] = (seg.path, seg.length, seg.speed, nxt, v_next, to.xyz[0], to.xyz[2],
                      math.nan if start.turn_signal is None else start.turn_signal,
                      -1 if start.brake_light is None else int(start.brake_light),
                      math.nan if start.head_light is None else max(0.0, start.head_light), quiet, to.waiting_s > 0.0)  # fmt: skip
        return out

    def choose_next(self, wp: str, preferred: frozenset[int], rng: np.random.Generator) -> int:
        """The segment taken at waypoint `wp` (-1 at an end point), drawn with `rng`."""
        out = self.outgoing.get(wp)
        if not out:
            return -1
        for k in out:
            if k in preferred:
                return k
        if len(out) == 1:
            return out[0]
        p = np.array([self.segments[k].probability for k in out])
        total = float(p.sum())
        r = float(rng.random())
        if total <= 0.0:
            return out[min(int(r * len(out)), len(out) - 1)]
        acc = np.cumsum(p / total)
        return out[min(int(np.searchsorted(acc, r, side="right")), len(out) - 1)]

    def start_on(self, wp: str, preferred: frozenset[int], rng: np.random.Generator) -> tuple[int, float] | None:
        """(segment, arc length) an object placed at waypoint `wp` continues on, or None."""
        k = self.choose_next(wp, preferred, rng)
        if k >= 0:
            return k, 0.0
        parents = self.parents.get(wp)
        if parents:  # a via waypoint: continue on a parent segment from there
            k = parents[int(rng.integers(len(parents)))] if len(parents) > 1 else parents[0]
            return k, self.segments[k].via_s[wp]
        return None
