"""The road surface in world coordinates: asphalt pieces and painted lines near a viewer.

Why: both views draw the same road. OpenDS tasks describe it in one of several ways, so we
use the first that the task has: an OpenDRIVE road (`world.road.opendrive`: every lane
between its edges, drivable lanes as asphalt, others as shoulder), the `road/lane`
X-bands (straight along Z, as OpenDS's reaction timers assume), the traffic road network
(Gen B segments or Gen A waypoints, one 3.5 m lane each), else the ideal tracks, else the
camera-flight track; plus, where the ego starts off all of them, the curve that joins it
to its road (`sim.lane_sources`). Ideal tracks are also returned as thin lines for the map. Markings: solid outer edges, dashed
lines between lanes (6 m paint, 12 m gap, as on German motorways), 0.15 m wide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..task.model_scene import Point
from . import palette as pal

MARK_HALF_W_M = 0.075
DASH_M, GAP_M = 6.0, 12.0
PERIOD_M = DASH_M + GAP_M
SHOULDER_M = 0.5
PATH_LANE_HALF_W_M = 1.75  # a traffic path or ideal track is drawn as one 3.5 m lane each side
RESAMPLE_M = 3.0
CAR_LANES = frozenset({"driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp", "mwyEntry", "mwyExit", "bidirectional"})
_ASPHALT = np.asarray(pal.ASPHALT, float)
_MARKING = np.asarray(pal.MARKING, float)


@dataclass
class Ribbon:
    """A strip of road between two edge polylines (N, 2), with painted lines along it."""

    left: np.ndarray
    right: np.ndarray
    color: tuple[int, int, int] = pal.ASPHALT
    marks: tuple[tuple[np.ndarray, bool], ...] = ()  # (points (N, 2), dashed)
    centre: np.ndarray = field(init=False)
    s: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.centre = 0.5 * (self.left + self.right)
        d = np.diff(self.centre, axis=0)
        self.s = np.concatenate([[0.0], np.cumsum(np.hypot(d[:, 0], d[:, 1]))])


@dataclass
class GroundPieces:
    quads: np.ndarray  # (N, 4, 2) world x, z
    quad_colors: np.ndarray  # (N, 3)
    lines: np.ndarray  # (M, 4) x0, z0, x1, z1
    line_half_w: np.ndarray  # (M,)
    line_colors: np.ndarray  # (M, 3)


def resample(points: Any, step: float = RESAMPLE_M) -> np.ndarray | None:
    """A polyline (x, z) with points at most `step` apart (None if it has no length)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-6])
    pts = pts[keep]
    if len(pts) < 2:
        return None
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    si = np.linspace(0.0, s[-1], max(2, int(math.ceil(s[-1] / step)) + 1))
    return np.stack([np.interp(si, s, pts[:, 0]), np.interp(si, s, pts[:, 1])], axis=1)


def offset_polyline(xz: np.ndarray, offset: float) -> np.ndarray:
    """The polyline moved sideways by `offset` metres (positive to the left of travel)."""
    d = np.diff(xz, axis=0)
    t = np.zeros_like(xz)
    t[:-1] += d
    t[1:] += d
    t /= np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-9)[:, None]
    left = np.stack([t[:, 1], -t[:, 0]], axis=1)  # forward -Z -> left -X, as in sim.road
    return xz + offset * left


class RoadLayout:
    """A world's road, built once; `pieces()` cuts out what is near a viewer."""

    def __init__(self, world: Any) -> None:
        road = world.road
        task = world.task
        self.bands = tuple(road.lanes)
        self.ribbons: list[Ribbon] = []
        self.tracks = [pl.xz for pl, _ in road.ideal_tracks.values()]
        od = getattr(road, "opendrive", None)
        if od is not None:
            self.ribbons.extend(opendrive_ribbons(od))
        elif not self.bands:
            points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}
            for path in _network_paths(task, points) or self.tracks or _camera_flight_path(task, points):
                self._add_path(path)
        connector = _start_connector(world)
        if connector is not None:  # the ego's own road onto the task's roads (lane_sources)
            self._add_path(connector)
        if self.bands:
            lo = min(b.x_min for b in self.bands)
            hi = max(b.x_max for b in self.bands)
            self.band_x = (lo - SHOULDER_M, hi + SHOULDER_M)
            edges: dict[float, int] = {}
            for b in self.bands:
                for e in (round(b.x_min, 2), round(b.x_max, 2)):
                    edges[e] = edges.get(e, 0) + 1
            self.band_marks = tuple((e, n > 1) for e, n in sorted(edges.items()))  # shared edges are dashed

    def _add_path(self, path: Any) -> None:
        """A path drawn as one 3.5 m lane with solid edges and a shoulder."""
        xz = resample(path)
        if xz is None:
            return
        left, right = offset_polyline(xz, PATH_LANE_HALF_W_M), offset_polyline(xz, -PATH_LANE_HALF_W_M)
        self.ribbons.append(
            Ribbon(
                offset_polyline(xz, PATH_LANE_HALF_W_M + SHOULDER_M),
                offset_polyline(xz, -PATH_LANE_HALF_W_M - SHOULDER_M),
                pal.ASPHALT,
                ((left, False), (right, False)),
            )
        )

    # ------------------------------------------------------------------ cut out
    def pieces(self, x: float, z: float, radius: float, breaks: np.ndarray | None = None, dash_radius: float = 300.0) -> GroundPieces:
        """Road near (x, z). `breaks` (ascending distances from the viewer) subdivide long
        pieces so the 3D view can fog and clip them; the map passes none."""
        quads: list[np.ndarray] = []
        colors: list[np.ndarray] = []
        lines: list[np.ndarray] = []
        if self.bands:
            self._band_pieces(x, z, radius, breaks, dash_radius, quads, lines)
            colors.append(np.broadcast_to(_ASPHALT, (len(quads[-1]) if quads else 0, 3)))
        for r in self.ribbons:
            n = self._ribbon_pieces(r, x, z, radius, dash_radius, quads, lines)
            if n:
                colors.append(np.broadcast_to(np.asarray(r.color, float), (n, 3)))
        q = (quads[0] if len(quads) == 1 else np.concatenate(quads)) if quads else np.zeros((0, 4, 2))
        c = (colors[0] if len(colors) == 1 else np.concatenate(colors)) if colors else np.zeros((0, 3))
        ln = (lines[0] if len(lines) == 1 else np.concatenate(lines)) if lines else np.zeros((0, 4))
        return GroundPieces(q, c, ln, np.broadcast_to(MARK_HALF_W_M, (len(ln),)), np.broadcast_to(_MARKING, (len(ln), 3)))

    def track_lines(self, x: float, z: float, radius: float) -> np.ndarray:
        """Ideal-track segments (x0, z0, x1, z1) near (x, z), for the map."""
        out = []
        for xz in self.tracks:
            near = np.hypot(xz[:, 0] - x, xz[:, 1] - z) <= radius
            seg = near[:-1] | near[1:]
            if seg.any():
                out.append(np.concatenate([xz[:-1][seg], xz[1:][seg]], axis=1))
        return np.concatenate(out) if out else np.zeros((0, 4))

    def _band_pieces(
        self,
        x: float,
        z: float,
        radius: float,
        breaks: np.ndarray | None,
        dash_radius: float,
        quads: list[np.ndarray],
        lines: list[np.ndarray],
    ) -> None:
        lo, hi = self.band_x
        if x + radius < lo or x - radius > hi:
            return
        if breaks is None:
            zs = np.array([z - radius, z + radius])
        else:
            rel = breaks[breaks < radius]
            zs = np.concatenate([[z - radius], z - rel[::-1], [z], z + rel, [z + radius]])
        z0, z1 = zs[:-1], zs[1:]
        n = len(z0)
        q = np.empty((n, 4, 2))
        q[:, 0, 0] = q[:, 3, 0] = lo
        q[:, 1, 0] = q[:, 2, 0] = hi
        q[:, 0, 1] = q[:, 1, 1] = z0
        q[:, 2, 1] = q[:, 3, 1] = z1
        quads.append(q)
        dr = min(radius, dash_radius)
        k = np.arange(math.floor((z - dr) / PERIOD_M), math.ceil((z + dr) / PERIOD_M) + 1) * PERIOD_M
        dashed = [e for e, d in self.band_marks if d]
        solid = [e for e, d in self.band_marks if not d]
        if dashed:
            ln = np.empty((len(dashed), len(k), 4))
            ln[:, :, 0] = ln[:, :, 2] = np.asarray(dashed)[:, None]
            ln[:, :, 1] = k
            ln[:, :, 3] = k + DASH_M
            lines.append(ln.reshape(-1, 4))
        if solid:
            ln = np.empty((len(solid), n, 4))
            ln[:, :, 0] = ln[:, :, 2] = np.asarray(solid)[:, None]
            ln[:, :, 1] = z0
            ln[:, :, 3] = z1
            lines.append(ln.reshape(-1, 4))

    @staticmethod
    def _ribbon_pieces(
        r: Ribbon, x: float, z: float, radius: float, dash_radius: float, quads: list[np.ndarray], lines: list[np.ndarray]
    ) -> int:
        d = np.hypot(r.centre[:, 0] - x, r.centre[:, 1] - z)
        idx = np.flatnonzero(d <= radius + RESAMPLE_M)
        if len(idx) < 2:
            return 0
        # level of detail: far away keep every 2^k-th point (k grows with distance)
        stride = np.clip(2 ** np.floor(np.log2(np.maximum(d[idx] / 40.0, 1.0))), 1, 32).astype(int)
        idx = idx[(idx % stride == 0) | (idx == len(r.centre) - 1)]
        a, b = idx[:-1], idx[1:]
        ok = (b - a) <= 32
        a, b = a[ok], b[ok]
        if not len(a):
            return 0
        quads.append(np.stack([r.left[a], r.left[b], r.right[b], r.right[a]], axis=1))
        s_mid = 0.5 * (r.s[a] + r.s[b])
        near_dash = (d[a] <= dash_radius) & ((s_mid % PERIOD_M) < DASH_M) & ((b - a) == 1)
        for pts, dashed in r.marks:
            sel = near_dash if dashed else np.ones(len(a), bool)
            if sel.any():
                lines.append(np.concatenate([pts[a[sel]], pts[b[sel]]], axis=1))
        return len(a)


def opendrive_ribbons(od: Any, step: float = RESAMPLE_M) -> list[Ribbon]:
    """One ribbon per lane and lane section of an `OpenDriveMap` (world x = x, z = -y)."""
    out: list[Ribbon] = []
    for road in od.roads.values():
        for sec in road.sections:
            n = max(2, int(math.ceil((sec.s1 - sec.s0) / step)) + 1)
            s = np.linspace(sec.s0, sec.s1, n)
            ref = road.reference.evaluate(s)
            sin_h, cos_h = np.sin(ref.hdg), np.cos(ref.hdg)

            def world(t: np.ndarray, ref: Any = ref, sin_h: np.ndarray = sin_h, cos_h: np.ndarray = cos_h) -> np.ndarray:
                return np.stack([ref.x - t * sin_h, -(ref.y + t * cos_h)], axis=1)

            edges = od.lane_edges(road, sec, s)
            in_junction = str(road.junction) != "-1"
            for side in (sec.left, sec.right):
                for k, lane in enumerate(side):
                    inner, outer = edges[lane.id]
                    if np.all(np.abs(outer - inner) < 0.05):
                        continue
                    drivable = lane.type in CAR_LANES
                    marks: tuple[tuple[np.ndarray, bool], ...] = ()
                    if drivable and not in_junction:
                        nxt = side[k + 1] if k + 1 < len(side) else None
                        outer_dashed = nxt is not None and nxt.type in CAR_LANES
                        marks = ((world(outer), outer_dashed),)
                        if k == 0:
                            marks += ((world(inner), True),)  # the centre line between the two directions
                    out.append(Ribbon(world(inner), world(outer), pal.ASPHALT if drivable else pal.SHOULDER, marks))
    return out


def _start_connector(world: Any) -> np.ndarray | None:
    """Where the ego starts off every road the task describes (the MotorwayTask car stands on
    a slip road of its 3D model), the curve `sim.lane_sources` joins it to them by, (N, 2)."""
    from ..sim.lane_sources import ego_road

    start = getattr(world, "start_pose", None)
    if start is None or world.road.lanes or not hasattr(world.task, "scenario"):
        return None
    road = ego_road(world.task, world.road, start)
    if road is None or road.join_s_m <= 0.0:
        return None
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(road.points, axis=0).T))])
    out: np.ndarray = road.points[arc <= road.join_s_m + 1e-6]
    return out


def _camera_flight_path(task: Any, points: dict[str, tuple[float, float, float]]) -> list[list[tuple[float, float]]]:
    """The camera-flight track (ConTRe drives along it) when a task gives no other road."""
    flight = task.scenario.driver.camera_flight
    if flight is None:
        return []
    xz = []
    for p in flight.track:
        pos = p.translation_m if p.translation_m is not None else points.get(p.ref)
        if pos is not None:
            xz.append((pos[0], pos[2]))
    return [xz] if len(xz) >= 2 else []


def _network_paths(task: Any, points: dict[str, tuple[float, float, float]]) -> list[list[tuple[float, float]]]:
    """Polylines (x, z) of the traffic road network: Gen B segments, else Gen A vehicle waypoints."""
    road = task.scenario.road
    out: list[list[tuple[float, float]]] = []
    if road.segments is not None and road.way_points is not None:
        wps = {}
        for wp in road.way_points.points:
            pos = wp.translation_m or points.get(wp.ref)
            if pos is not None:
                wps[wp.key] = (pos[0], pos[2])
        for seg in road.segments.items:
            path = [wps[k] for k in (seg.from_wp, *seg.via, seg.to_wp) if k in wps]
            if len(path) >= 2 and not seg.jump:
                out.append(path)
    if not out:
        for vehicle in task.scenario.vehicles:
            path = []
            for wp in vehicle.way_points:
                pos = wp.translation_m or points.get(wp.ref)
                if pos is not None:
                    path.append((pos[0], pos[2]))
            if len(path) >= 2:
                if vehicle.path_is_cycle:
                    path.append(path[0])
                out.append(path)
    return out
