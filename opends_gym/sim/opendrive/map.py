"""`OpenDriveMap`: OpenDRIVE roads in world coordinates -- locate, lane centres, routes.

Why: OpenDS 2023 tasks start the driver on `startRoadID/startLane/startS`, drive traffic
along OpenDRIVE lanes, place models by `openDrivePosition` and fire `openDrivePos`
triggers when a car passes `s` on a road and lane. All of that needs two directions of
one mapping: road coordinates (road, lane, s) to world points, and world points back to
road coordinates (`locate`, called every physics step by the trigger core).

Coordinates. OpenDRIVE has x east, y north, heading counter-clockwise from +x. OpenDS maps
a reference-line point to jME world coordinates as `(x, elevation, -y)`
(AnnegretJ/openDS `ODRoad.getStartPos` / `getPositionOnLine`: `new Vector3d(x, 0, -y)`),
so world x = OpenDRIVE x, world z = -OpenDRIVE y, world Y up. A heading `h` in OpenDRIVE
is our yaw `h - pi/2` (yaw 0 faces -Z, positive yaw turns left). init_drive confirms it:
its road at OpenDRIVE y = -100 runs along world z = +100, where the scenario's
pedestrians stand. Traffic is right-handed, as in OpenDS: lanes with negative ids drive
towards increasing s, positive ids towards decreasing s (`ODLane.getLaneCenterPointAhead`).

`position_to_world` follows OpenDS's `MapObjectOD` for models placed by
`openDrivePosition`: the point on the *reference line* at s, moved by the lateral offset
as `x + off*sin(h)`, `z + off*cos(h)` -- positive offsets lie to the right of the +s
direction -- and the model faces +s (yaw `h - pi/2`, plus its own yaw).
"""

from __future__ import annotations

import bisect
import functools
import itertools
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ...task.layer_checks import register as register_layer_check
from ...task.model_task import DrivingTask, Pose
from ...task.values import Rotation
from .parse import Junction, LaneSection, OpenDriveError, ParsedOpenDrive, Road, parse_opendrive
from .route import CAR_LANE_TYPES, RoutePlanner

__all__ = ["CAR_LANE_TYPES", "OpenDriveError", "OpenDriveMap", "driver_start_pose"]

_CELL_M = 10.0  # grid cell of the locate index
_SAMPLE_M = 1.0  # spacing of the reference-line samples in the index
_S_TOL_M = 1e-6


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def yaw_from_od_heading(h: float) -> float:
    """Our yaw (0 faces -Z, + turns left) for a direction of heading h in OpenDRIVE."""
    return wrap_angle(h - 0.5 * math.pi)


class OpenDriveMap:
    """An OpenDRIVE road network, immutable after loading (safe to share between Worlds)."""

    def __init__(self, parsed: ParsedOpenDrive) -> None:
        self.path: Path = parsed.path
        self.roads: dict[str, Road] = parsed.roads
        self.junctions: dict[str, Junction] = parsed.junctions
        self.warnings: list[str] = list(parsed.warnings)
        self._road_list = list(self.roads.values())
        self._build_index()
        self._planner = RoutePlanner(self)

    @classmethod
    def load(cls, path: str | Path) -> OpenDriveMap:
        """Read an .xodr file (cached by path, size and modification time)."""
        p = Path(path).resolve()
        try:
            st = p.stat()
        except OSError as e:
            raise OpenDriveError(f"cannot read file: {e.strerror or e}", p) from e
        return _load_cached(str(p), st.st_mtime_ns, st.st_size)

    # ------------------------------------------------------------------ road coordinates
    def road(self, road_id: str) -> Road:
        road = self.roads.get(str(road_id))
        if road is None:
            raise ValueError(f"{self.path.name}: no road '{road_id}' (roads: {', '.join(sorted(self.roads))})")
        return road

    def check_s(self, road: Road, s: float) -> float:
        s = float(s)
        if not (-_S_TOL_M <= s <= road.length + _S_TOL_M):
            raise ValueError(f"{self.path.name}: s={s} is outside road '{road.id}' (0..{road.length})")
        return min(max(s, 0.0), road.length)

    def section_index(self, road: Road, s: float, lane_id: int | None = None) -> int:
        """The lane section holding s; on a boundary, the one that has `lane_id`."""
        i = max(0, bisect.bisect_right(road.sections, s, key=lambda sec: sec.s0) - 1)
        if lane_id is not None and lane_id not in road.sections[i].lanes and i > 0 and abs(road.sections[i - 1].s1 - s) < 1e-6:
            i -= 1
        return i

    def lane_edges(self, road: Road, sec: LaneSection, s: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """(inner, outer) lateral offset t of every lane at s (t > 0 left of the reference line)."""
        off = road.lane_offset(s)
        ds = s - sec.s0
        out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for side, sign in ((sec.left, 1.0), (sec.right, -1.0)):
            cum = np.zeros_like(s)
            for lane in side:
                w = lane.width(ds) if not lane.width.empty else np.abs(lane.border(ds)) - cum
                w = np.maximum(w, 0.0)
                out[lane.id] = (off + sign * cum, off + sign * (cum + w))
                cum = cum + w
        return out

    def lane_center_t(self, road: Road, sec: LaneSection, lane_id: int, s: np.ndarray) -> np.ndarray:
        if lane_id not in sec.lanes:
            raise ValueError(f"{self.path.name}: road '{road.id}' has no lane {lane_id} at s={float(np.min(s)):.2f}")
        inner, outer = self.lane_edges(road, sec, s)[lane_id]
        return 0.5 * (inner + outer)

    def _world(self, road: Road, s: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ref = road.reference.evaluate(s)
        x = ref.x - t * np.sin(ref.hdg)
        y = ref.y + t * np.cos(ref.hdg)
        return x, -y

    def lane_points(self, road: Road, sec: LaneSection, lane_id: int, s: np.ndarray) -> np.ndarray:
        """World (x, z) of a lane's centre line at the given s values, shape (K, 2)."""
        x, z = self._world(road, s, self.lane_center_t(road, sec, lane_id, s))
        return np.column_stack([x, z])

    def _lane_t(self, road: Road, sec: LaneSection, lane_id: int, s: float) -> float:
        """Lateral offset of a lane's centre at one s (scalar twin of `lane_center_t`)."""
        side, sign = (sec.left, 1.0) if lane_id > 0 else (sec.right, -1.0)
        ds = s - sec.s0
        cum = 0.0
        for lane in side:
            w = max(lane.width.at(ds) if not lane.width.empty else abs(lane.border.at(ds)) - cum, 0.0)
            if lane.id == lane_id:
                return road.lane_offset.at(s) + sign * (cum + 0.5 * w)
            cum += w
        raise ValueError(f"{self.path.name}: road '{road.id}' has no lane {lane_id} at s={s:.2f}")

    def _point(self, road: Road, s: float, t: float) -> tuple[float, float]:
        x, y, h, _ = road.reference.point(s)
        return x - t * math.sin(h), -(y + t * math.cos(h))

    def lane_center(self, road_id: str, lane_id: int, s: float) -> tuple[float, float, float]:
        """World (x, z, yaw) of a lane's centre at s; yaw faces the lane's driving direction."""
        road = self.road(road_id)
        s = self.check_s(road, s)
        lane_id = int(lane_id)
        sec = road.sections[self.section_index(road, s, lane_id)]
        x, z = self._point(road, s, self._lane_t(road, sec, lane_id, s))
        a, b = max(sec.s0, s - 0.05), min(sec.s1, s + 0.05)
        xa, za = self._point(road, a, self._lane_t(road, sec, lane_id, a))
        xb, zb = self._point(road, b, self._lane_t(road, sec, lane_id, b))
        dx, dz = xb - xa, zb - za
        if lane_id > 0:  # left lanes drive towards decreasing s
            dx, dz = -dx, -dz
        return x, z, math.atan2(-dx, -dz)

    def position_to_world(self, road_id: str, s: float, lateral_offset: float = 0.0) -> tuple[float, float, float]:
        """World (x, z, yaw) of a model placed by `openDrivePosition` (see module docstring)."""
        road = self.road(road_id)
        s = self.check_s(road, s)
        x, y, h, _ = road.reference.point(s)
        return x + lateral_offset * math.sin(h), -y + lateral_offset * math.cos(h), yaw_from_od_heading(h)

    def elevation_m(self, road_id: str, s: float) -> float:
        """Height of the road's reference line at s (world Y)."""
        road = self.road(road_id)
        return road.elevation.at(self.check_s(road, s))

    # ------------------------------------------------------------------ world -> road
    def _build_index(self) -> None:
        """Reference-line samples with the road's half-width, bucketed into a square grid."""
        xs, ys, ss, ridx, reach = [], [], [], [], []
        for i, road in enumerate(self._road_list):
            n = max(2, int(math.ceil(road.length / _SAMPLE_M)) + 1)
            s = np.linspace(0.0, road.length, n)
            ref = road.reference.evaluate(s)
            half = np.zeros_like(s)
            for k, sec in enumerate(road.sections):
                m = (s >= sec.s0) & ((s < sec.s1) if k + 1 < len(road.sections) else (s <= sec.s1 + 1e-9))
                if not m.any():
                    continue
                for inner, outer in self.lane_edges(road, sec, s[m]).values():
                    half[m] = np.maximum(half[m], np.maximum(np.abs(inner), np.abs(outer)))
            xs.append(ref.x)
            ys.append(ref.y)
            ss.append(s)
            ridx.append(np.full(n, i))
            reach.append(half + road.length / (n - 1) + 1.0)
        self._sx, self._sy, self._ss = np.concatenate(xs), np.concatenate(ys), np.concatenate(ss)
        self._sroad = np.concatenate(ridx)
        r = np.concatenate(reach)
        lo_x = np.floor((self._sx - r) / _CELL_M).astype(np.int64)
        hi_x = np.floor((self._sx + r) / _CELL_M).astype(np.int64)
        lo_y = np.floor((self._sy - r) / _CELL_M).astype(np.int64)
        hi_y = np.floor((self._sy + r) / _CELL_M).astype(np.int64)
        span = int(max((hi_x - lo_x).max(), (hi_y - lo_y).max())) + 1
        keys_x, keys_y, members = [], [], []
        idx = np.arange(len(self._sx))
        for ox in range(span):
            for oy in range(span):
                m = (lo_x + ox <= hi_x) & (lo_y + oy <= hi_y)
                keys_x.append(lo_x[m] + ox)
                keys_y.append(lo_y[m] + oy)
                members.append(idx[m])
        kx, ky, mem = np.concatenate(keys_x), np.concatenate(keys_y), np.concatenate(members)
        order = np.lexsort((mem, ky, kx))
        kx, ky, mem = kx[order], ky[order], mem[order]
        change = np.flatnonzero((np.diff(kx) != 0) | (np.diff(ky) != 0)) + 1
        bounds = np.concatenate([[0], change, [len(kx)]])
        # each cell: per road, the indices of its samples that may reach into the cell
        self._cells: dict[tuple[int, int], list[tuple[Road, np.ndarray]]] = {}
        for a, b in itertools.pairwise(bounds):
            members_ab = mem[a:b]
            groups = self._sroad[members_ab]
            self._cells[(int(kx[a]), int(ky[a]))] = [(self._road_list[int(ri)], members_ab[groups == ri]) for ri in np.unique(groups)]

    def _project(self, road: Road, x: float, y: float, s: float) -> tuple[float, float] | None:
        """Foot point (s, t) of OpenDRIVE point (x, y) on the road's reference line (Newton)."""
        ref = road.reference
        for _ in range(12):
            rx, ry, h, k = ref.point(s)
            dx, dy = x - rx, y - ry
            c, sn = math.cos(h), math.sin(h)
            along, t = dx * c + dy * sn, -dx * sn + dy * c
            s_new = min(max(s + along / max(1.0 - k * t, 0.2), 0.0), road.length)
            if abs(s_new - s) < 1e-7:
                break
            s = s_new
        rx, ry, h, _ = ref.point(s)
        dx, dy = x - rx, y - ry
        along, t = dx * math.cos(h) + dy * math.sin(h), -dx * math.sin(h) + dy * math.cos(h)
        if abs(along) > 1e-3:  # beyond an end of the road
            return None
        return s, t

    def _lane_at(self, road: Road, s: float, t: float, lane_types: frozenset[str] | None) -> tuple[int, float] | None:
        """(lane id, distance from that lane's centre) of lateral offset t at s, or None off the road."""
        sec = road.sections[self.section_index(road, s)]
        off = road.lane_offset.at(s)
        ds = s - sec.s0
        side, sign = (sec.left, 1.0) if t >= off else (sec.right, -1.0)
        d = (t - off) * sign  # distance outwards from the centre lane
        cum = 0.0
        for lane in side:
            w = max(lane.width.at(ds) if not lane.width.empty else abs(lane.border.at(ds)) - cum, 0.0)
            if cum <= d < cum + w or (d == 0.0 and w > 0.0):
                if lane_types is not None and lane.type not in lane_types:
                    return None
                return lane.id, abs(d - cum - 0.5 * w)
            cum += w
        return None

    def locate(self, x: float, z: float, lane_types: Iterable[str] | None = None) -> tuple[str, int, float] | None:
        """(road id, lane id, s) of the lane holding world point (x, z), or None off every road.

        Where roads overlap (junctions), the lane whose centre is nearest wins. Lanes of
        every type count unless `lane_types` names the allowed ones (e.g. CAR_LANE_TYPES).
        """
        if not (math.isfinite(x) and math.isfinite(z)):
            return None
        X, Y = float(x), -float(z)
        cell = self._cells.get((math.floor(X / _CELL_M), math.floor(Y / _CELL_M)))
        if cell is None:
            return None
        allowed = frozenset(lane_types) if lane_types is not None else None
        best: tuple[float, str, int, float] | None = None
        for road, idx in cell:
            k = int(idx[np.argmin((self._sx[idx] - X) ** 2 + (self._sy[idx] - Y) ** 2)])
            foot = self._project(road, X, Y, float(self._ss[k]))
            if foot is None:
                continue
            hit = self._lane_at(road, foot[0], foot[1], allowed)
            if hit is not None and (best is None or hit[1] < best[0] - 1e-9):
                best = (hit[1], road.id, hit[0], foot[0])
        return None if best is None else (best[1], best[2], best[3])

    # ------------------------------------------------------------------ routes
    def route(
        self,
        start_road_id: str,
        start_lane: int,
        start_s: float,
        target_road_id: str | None = None,
        target_lane: int | None = None,
        target_s: float | None = None,
        preferred_connections: Iterable[Any] = (),
        *,
        lane_types: Iterable[str] = CAR_LANE_TYPES,
        max_length_m: float = 10_000.0,
        step_m: float = 1.0,
    ) -> np.ndarray:
        """World (x, z) points along lane centres, ~`step_m` apart, in the lanes' driving direction.

        Follows lane links through lane sections, road successors/predecessors and
        junction connections (those in `preferred_connections` first -- ODConnection
        objects or (junctionID, connectionID) pairs -- then the first that can still
        reach the target, then the first valid one), and stops at the target (road, s),
        at the end of the target road when no target s is given, at a dead end, or after
        `max_length_m`. The route never changes lanes by itself.
        """
        return self._planner.route(
            start_road_id,
            start_lane,
            start_s,
            target_road_id,
            target_lane,
            target_s,
            preferred_connections,
            lane_types,
            max_length_m,
            step_m,
        )


@functools.lru_cache(maxsize=8)
def _load_cached(path: str, _mtime_ns: int, _size: int) -> OpenDriveMap:
    return OpenDriveMap(parse_opendrive(path))


def driver_start_pose(task: DrivingTask, od: OpenDriveMap | None) -> Pose | None:
    """The ego's start from `scenario/driver/openDrive` (lane centre, facing the lane's direction)."""
    spec = task.scenario.driver.open_drive
    if od is None or spec is None or spec.start_road_id is None or spec.start_lane is None:
        return None
    s = spec.start_s_m or 0.0
    where = task.folder / task.entry.scenario
    try:
        x, z, yaw = od.lane_center(spec.start_road_id, spec.start_lane, s)
        y = od.elevation_m(spec.start_road_id, s)
    except ValueError as e:
        raise OpenDriveError(f"driver start position: {e}", where, None, "openDrive") from e
    return Pose((x, y, z), Rotation.from_euler_deg(0.0, math.degrees(yaw), 0.0))


# load_task and `validate` check the task's road.xodr with the same reader gym.make uses
# (and fill its cache), so a broken file fails at load time naming file and line.
register_layer_check("openDrive", OpenDriveMap.load)
