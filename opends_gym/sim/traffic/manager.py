"""`TrafficManager`: the traffic cars and pedestrians of a World (OpenDS `PhysicalTraffic`).

Why: OpenDS tasks fill their roads with cars that follow waypoints (Gen A), roam a road
network of segments (Gen B) or follow OpenDRIVE lanes (2023), and with pedestrians; the
ego car reacts to them (ACC, collisions) and envs observe them. This module owns their
state as numpy arrays, one row per object, vehicles first in `task.scenario.vehicles`
order, then pedestrians, then ODvehicles:

    ids (tuple), positions (N,3) m, yaw (N,) rad (0 faces -Z, positive turns left),
    speed (N,) m/s, enabled (N,) bool, brake_light (N,) bool,
    turn_signal (N,) int (0 off, 1 left, 2 right, 3 both), half_extents (N,2) m
    (half width, half length), head_light (N,) intensity.

Cars follow the OpenDS follow-box rules (see `traffic.motion`); per-step work is array
maths over all objects, and leg ends are rare per-object events (`traffic_legs`).
Pedestrians walk their paths at the waypoint/segment speed. ODvehicles drive the lane
centre route of `OpenDriveMap.route` at `maxSpeed` (50 km/h when absent) and stop at its
end; without an OpenDRIVE map they stay disabled (a warning names them).

Differences from OpenDS, all for determinism or robustness: simulation time instead of
wall-clock waits; a traffic car starts at rest where OpenDS places it; a speed override
*replaces* the path speed (OpenDS took the minimum), so the platoon/brake envs can make a
lead car faster or slower; `resetWhenStuck` resets cars too (OpenDS only ever collected
positions of pedestrians), using 7 one-second samples that moved less than 0.3 m in all.
"""

from __future__ import annotations

import copy
import logging
import math
from typing import Any, Protocol

import numpy as np

from ...task.model_task import DrivingTask
from ...task.model_traffic import ODVehicle, Pedestrian, TrafficVehicle
from ..geometry2d import Obb
from ..lights import TrafficLights
from ..road import RoadModel
from .controls import ControlsWorld, TrafficControls
from .legs import KIND_NET, KIND_NONE, KIND_OD, KIND_OWN
from .motion import ARRIVED, BLOCK, N_WORK, NOTHING_LIVE, PASSED_LIGHT, WAIT_OVER, WAITS_OVER, advance_carrots, drive, step_objects
from .paths import PathBank
from .queries import nearest_ahead, touching
from .routes import OwnPath, PositionResolver, RoadNetwork, build_own_path
from .state import N_COLUMNS, MotionState, Specs


class TrafficWorld(ControlsWorld, Protocol):
    """What traffic reads of its World (the World is one): the task, the clock and event log,
    the road (OpenDRIVE lanes), the lights (stop lines) and, through the leg logic, the
    seeded generator and the ego car."""

    task: DrivingTask
    road: RoadModel
    lights: TrafficLights | None


log = logging.getLogger(__name__)

CAR_HALF = (0.9, 2.2)
TRUCK_HALF = (1.25, 5.0)
PEDESTRIAN_HALF = (0.3, 0.25)
LEAD_HALF_WIDTH_M, LEAD_RANGE_M = 1.5, 250.0
STUCK_TOTAL_M = 0.3
OD_SPEED_MPS = 50.0 / 3.6


class TrafficManager(TrafficControls):
    """Traffic of one World; see the module docstring for the arrays it exposes."""

    world: TrafficWorld

    def __init__(self, world: TrafficWorld) -> None:
        self.world = world
        task = world.task
        sc = task.scenario
        self.objects: list[TrafficVehicle | Pedestrian | ODVehicle] = [*sc.vehicles, *sc.pedestrians, *sc.od_vehicles]
        self.ids: tuple[str, ...] = tuple(o.id for o in self.objects)
        self._index: dict[str, int] = {}
        for i, oid in enumerate(self.ids):
            self._index.setdefault(oid, i)
        n = len(self.ids)
        self.lights = world.lights
        self.paths = PathBank()
        where = PositionResolver(task)
        self.network: RoadNetwork | None = RoadNetwork(task, self.paths, where) if sc.road.segments or sc.road.way_points else None
        self.od_map: Any = getattr(world.road, "opendrive", None)
        self.own: list[OwnPath | None] = [None] * n
        self.kind = np.full(n, KIND_NONE, dtype=np.int64)
        self.preferred: list[frozenset[int]] = [frozenset()] * n
        self._od_route: dict[int, int] = {}
        self._warnings: list[tuple[str, str]] = []
        for i, o in enumerate(self.objects):
            try:
                self._setup(i, o, where)
            except Exception as e:  # a broken path disables its object; the run goes on
                self._warn(o.id, f"{type(o).__name__} '{o.id}' (line {o.line}) cannot move and stays disabled: {e}")
        self._base_paths = len(self.paths)
        self.is_car = np.array([not isinstance(o, Pedestrian) for o in self.objects], dtype=bool)
        self.half_extents = np.array([_half_extents(o) for o in self.objects], dtype=float).reshape(n, 2)
        vehicles = [o if not isinstance(o, Pedestrian) else None for o in self.objects]
        f = lambda get, default: np.array([get(o) if o is not None else default for o in vehicles], dtype=float)  # noqa: E731
        self.sp = Specs(
            is_car=self.is_car,
            accel=f(lambda o: o.acceleration_mps2, 0.0),
            dec_brake=f(lambda o: o.deceleration_brake_mps2, 8.7),
            dec_free=f(lambda o: o.deceleration_free_wheel_mps2, 2.0),
            min_dist=np.array([_min_dist(o) for o in self.objects], dtype=float),
            max_dist=np.array([_max_dist(o) for o in self.objects], dtype=float),
            max_speed=np.array([(o.max_speed_mps if o.max_speed_mps else math.inf) for o in self.objects], dtype=float),
            never_faster=np.array([bool(getattr(o, "never_faster_than_steering_car", False)) for o in self.objects], dtype=bool),
        )
        self._give_way_m = np.array([getattr(o, "give_way_distance_m", None) or 15.0 for o in self.objects], dtype=float)
        self._observe_m = np.array([getattr(o, "intersection_observation_distance_m", None) or 15.0 for o in self.objects])
        self._clearance_s = np.array([getattr(o, "min_intersection_clearance_m", None) or 5.0 for o in self.objects], dtype=float)
        self._stuck_reset = np.array([bool(getattr(o, "reset_when_stuck", False)) for o in self.objects], dtype=bool)
        segs = self.network.segments if self.network is not None else []
        self._seg_prio = np.array([bool(s.give_way) for s in segs] or [False], dtype=bool)
        self._seg_nb = np.array([s.left >= 0 or s.right >= 0 for s in segs] or [False], dtype=bool)
        # fixed facts the per-step code tests (so it skips what a task does not have)
        self._any_seg_prio = self.network is not None and bool(self._seg_prio.any())
        self._any_seg_nb = self.network is not None and bool(self._seg_nb.any())
        self._half_diag = np.hypot(self.half_extents[:, 0], self.half_extents[:, 1])
        # road-network legs that end without a choice to make are continued by the kernel
        lights = self.lights
        self._net_table = self.network.continuations(lambda name: lights is not None and lights.index_of(name) is not None) \
            if self.network is not None else np.zeros((1, N_COLUMNS))  # fmt: skip
        self._quiet_cars = np.array([k == KIND_NET and not p for k, p in zip(self.kind, self.preferred)], dtype=bool).reshape(n)
        self.st = MotionState.empty(n)
        self.light_queue: list[list[tuple[int, float, float]]] = [[] for _ in range(n)]
        # the kernels' per-step inputs and scratch (allocated once)
        self._work = np.zeros((N_WORK, n))
        self._flags = np.zeros(n, dtype=np.int64)
        self._all_rows = np.ones(n, dtype=bool)
        self._t_now = np.zeros(1)
        self._ego = np.zeros((3, 1))
        self._no_lights = np.zeros(1, dtype=bool)
        self._hits = np.zeros(n, dtype=np.int64)
        self._reach: tuple[tuple[float, float], np.ndarray] = ((math.nan, math.nan), np.zeros(n))
        self.brake_light = np.zeros(n, dtype=bool)
        self.turn_signal = np.zeros(n, dtype=np.int64)
        self.t_s = 0.0
        self._next_stuck_s = 1.0
        self.reset()

    def _setup(self, i: int, o: TrafficVehicle | Pedestrian | ODVehicle, where: PositionResolver) -> None:
        if isinstance(o, ODVehicle):
            if self.od_map is None:
                raise ValueError("ODvehicles drive on OpenDRIVE lanes and this task has no OpenDRIVE map")
            start = (o.start_road_id, o.start_lane, o.start_s_m)
            pts = np.asarray(self.od_map.route(*start, o.target_road_id, o.target_lane, o.target_s_m, o.preferred_connections))
            if len(pts) < 2:
                raise ValueError(f"no route from road {o.start_road_id} lane {o.start_lane} s {o.start_s_m}")
            y = self.od_map.elevation_m(o.start_road_id, o.start_s_m)
            self._od_route[i] = self.paths.add(np.column_stack([pts[:, 0], np.full(len(pts), y), pts[:, 1]]))
            self.kind[i] = KIND_OD
        elif o.way_points:
            self.own[i] = build_own_path(o, self.paths, where)  # type: ignore[call-overload]
            self.kind[i] = KIND_OWN
        else:
            if self.network is None or not o.start_way_point or o.start_way_point not in self.network.waypoints:
                raise ValueError(f"start waypoint '{o.start_way_point}' is not on the road network")
            self.preferred[i] = self.network.preferred(o.segment_refs)
            self.kind[i] = KIND_NET

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        self.t_s = 0.0
        self._next_stuck_s = 1.0
        self.paths.truncate(self._base_paths)
        n = len(self.ids)
        self.st = st = MotionState.empty(n)
        self.light_queue = [[] for _ in range(n)]
        for source, message in self._warnings:  # setup problems, repeated in every run's event log
            self.world.events.emit(self.world.t_s, "warning", source, message=message)
        for i, o in enumerate(self.objects):
            st.enabled[i] = bool(getattr(o, "enabled", True)) and self.kind[i] != KIND_NONE
            st.engine_on[i] = bool(getattr(o, "engine_on", True))
            if self.kind[i] == KIND_OWN:
                self._place_own(i, self.own[i].start)  # type: ignore[union-attr]
            elif self.kind[i] == KIND_NET:
                if not self._place_net(i, str(o.start_way_point)):  # type: ignore[union-attr]
                    self._event_warning(o.id, f"'{o.id}': its start waypoint is an end point; it stays disabled")
                    st.enabled[i] = False
            elif self.kind[i] == KIND_OD:
                cap = float(self.sp.max_speed[i])
                self._start_route(i, self._od_route[i], cap if math.isfinite(cap) else OD_SPEED_MPS)
        self._refresh_outputs()

    def get_state(self) -> dict[str, Any]:
        return {
            "t_s": self.t_s,
            "next_stuck_s": self._next_stuck_s,
            "st": self.st.copy(),
            "light_queue": copy.deepcopy(self.light_queue),
            "extra_paths": self.paths.extra(self._base_paths),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.t_s = state["t_s"]
        self._next_stuck_s = state["next_stuck_s"]
        self.st = state["st"].copy()
        self.light_queue = copy.deepcopy(state["light_queue"])
        self.paths.truncate(self._base_paths)
        for p in state["extra_paths"]:
            self.paths.add(p.copy())
        self._refresh_outputs()

    # ------------------------------------------------------------------ arrays
    @property
    def positions(self) -> np.ndarray:
        return self.st.pos

    @property
    def yaw(self) -> np.ndarray:
        return self.st.yaw

    @property
    def speed(self) -> np.ndarray:
        return self.st.speed

    @property
    def enabled(self) -> np.ndarray:
        return self.st.enabled

    @property
    def head_light(self) -> np.ndarray:
        return self.st.head_light

    # ------------------------------------------------------------------ stepping
    def step(self, dt_s: float) -> None:
        """One physics step: two compiled kernels (`traffic.motion`), with the rare per-object
        events (waits over, legs ended, lights passed, lane changes) in Python between them."""
        self.t_s += dt_s
        st, work, flags = self.st, self._work, self._flags
        pf, pp, pi = self.paths.arrays()
        self._t_now[0] = self.t_s
        ego = self.world.ego.state
        self._ego[0, 0], self._ego[1, 0], self._ego[2, 0] = ego.x, ego.z, ego.u
        stop = self.lights.stop_mask if self.lights is not None and len(self.lights.stop_mask) else self._no_lights
        if not self._any_seg_prio:  # the usual step: one call, unless an object needs Python
            code, passed = step_objects(st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, self.sp.packed, pf, pp, pi,
                                        self._t_now, self._ego, dt_s, work, flags, stop, self.brake_light, self.turn_signal,
                                        self._net_table, self._quiet_cars)  # fmt: skip
            if code == NOTHING_LIVE:
                return
            python_events = passed < 0
        else:
            code, python_events = advance_carrots(st.f, st.i, st.b, st.pos, self.sp.packed, pf, pp, pi, max(1, len(self.ids)),
                                                  self._all_rows, self._t_now, dt_s, work, flags), True  # fmt: skip
            if code == NOTHING_LIVE:
                return
        if python_events:
            passed = self._step_with_events(code, dt_s, stop)
        if passed:
            for i in np.flatnonzero(flags & PASSED_LIGHT):
                self._pop_light(int(i))
        if self._any_seg_nb:
            on_net = st.enabled & (st.pid >= 0) & self.is_car & (self.kind == KIND_NET) & ~st.ext
            self._passing_lanes(on_net & self._seg_nb[np.where(on_net, st.leg, 0)])
            python_events = True
        if self.t_s >= self._next_stuck_s - 1e-9:
            self._next_stuck_s += 1.0
            self._check_stuck(st.enabled & (st.pid >= 0) & self._stuck_reset)
            python_events = True
        if python_events:
            self._refresh_outputs()

    def _step_with_events(self, code: int, dt_s: float, stop: np.ndarray) -> int:
        """The rest of a step whose first kernel stopped for Python: waits that are over, legs
        that ended, give-way holds; then the second kernel. Returns the lights passed."""
        st, work, flags = self.st, self._work, self._flags
        pf, pp, pi = self.paths.arrays()
        n = max(1, len(self.ids))
        if code == WAITS_OVER:
            for i in np.flatnonzero(flags & WAIT_OVER):
                self._finish_wait(int(i))
            pf, pp, pi = self.paths.arrays()
            code = advance_carrots(st.f, st.i, st.b, st.pos, self.sp.packed, pf, pp, pi, n, self._all_rows, self._t_now, dt_s, work, flags)
        if code > 0:
            for i in np.flatnonzero(flags & ARRIVED):
                self._arrive(int(i))
            pf, pp, pi = self.paths.arrays()
        if self._any_seg_prio:
            self._hold_for_priority(flags)
        return int(drive(st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, self.sp.packed, pf, pp, pi, n, self._all_rows,
                         self._ego, dt_s, work, flags, code > 0, stop))  # fmt: skip

    def _hold_for_priority(self, flags: np.ndarray) -> None:
        """Cars on a `giveWayTo` segment near its end hold while prioritised traffic arrives too."""
        st = self.st
        on_net = st.enabled & (st.pid >= 0) & self.is_car & (self.kind == KIND_NET)
        rows = on_net & self._seg_prio[np.where(on_net, st.leg, 0)] & (st.leg_end - st.s < self._give_way_m)
        if rows.any():
            flags[self._give_way(rows, self._observe_m, self._clearance_s)] |= BLOCK

    def _check_stuck(self, rows: np.ndarray) -> None:
        st = self.st
        if not rows.any():
            return
        st.stuck_hist[rows, :-1] = st.stuck_hist[rows, 1:]
        st.stuck_hist[rows, -1] = st.pos[rows][:, [0, 2]]
        st.stuck_n = np.where(rows, np.minimum(st.stuck_n + 1, 7), st.stuck_n)
        moved = np.hypot(*np.diff(st.stuck_hist, axis=1).transpose(2, 0, 1)).sum(axis=1)
        for i in np.flatnonzero(rows & (st.stuck_n >= 7) & (moved < STUCK_TOTAL_M)):
            o = self.objects[i]
            self.world.events.emit(self.world.t_s, "traffic", o.id, what="reset_when_stuck")
            if self.kind[i] == KIND_OWN:
                self._place_own(int(i), self.own[i].start)  # type: ignore[union-attr]
            elif self.kind[i] == KIND_NET:
                self._place_net(int(i), str(o.start_way_point))  # type: ignore[union-attr]

    # ------------------------------------------------------------------ queries
    def index_of(self, obj_id: str) -> int | None:
        return self._index.get(obj_id)

    def lead_for_ego(self) -> tuple[float, float] | None:
        """(bumper gap m, speed along the ego's heading m/s) of the nearest car ahead in its lane."""
        if not self.ids:
            return None
        ego = self.world.ego
        s = ego.state
        fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
        st = self.st
        j, ahead = nearest_ahead(st.pos, st.enabled, self.is_car, s.x, s.z, fx, fz, -fz, fx, LEAD_HALF_WIDTH_M, LEAD_RANGE_M)
        if j < 0:
            return None
        gap = float(ahead - self.half_extents[j, 1] - 0.5 * ego.spec.length_m)
        return gap, float(st.speed[j] * math.cos(st.yaw[j] - s.yaw))

    def colliding_with(self, box: Obb) -> set[str]:
        """Ids of enabled objects whose boxes overlap `box` (the ego car's)."""
        if not self.ids:
            return set()
        st = self.st
        size = (box.hx, box.hz)
        if self._reach[0] != size:  # (the ego's box is the same every step)
            self._reach = (size, self._half_diag + math.hypot(box.hx, box.hz))
        n = touching(st.pos, st.yaw, self.half_extents, st.enabled, self._reach[1], box.cx, box.cz, box.yaw, box.hx, box.hz, self._hits)
        return {self.ids[j] for j in self._hits[:n]} if n else set()

    def road_position_of(self, obj_id: str) -> tuple[str, int, float] | None:
        """(OpenDRIVE road id, lane id, s) of an object, or None (no map, off the roads)."""
        i = self._need(obj_id)
        if self.od_map is None:
            return None
        result: tuple[str, int, float] | None = self.od_map.locate(float(self.st.pos[i, 0]), float(self.st.pos[i, 2]))
        return result

    # ------------------------------------------------------------------ actions
    def move_to_waypoint(self, obj_id: str, wp_id: str) -> bool:
        """OpenDS moveTraffic: teleport to a waypoint (own path or road network); speed kept."""
        i = self._need(obj_id)
        ok = False
        if self.kind[i] == KIND_OWN:
            own = self.own[i]
            k = own.index(wp_id) if own is not None else None
            if k is not None:
                self._place_own(i, k)
                ok = True
        elif self.kind[i] == KIND_NET and self.network is not None and wp_id in self.network.waypoints:
            ok = self._place_net(i, wp_id)
        if not ok:
            self._event_warning(obj_id, f"moveTraffic: '{obj_id}' cannot be moved to waypoint '{wp_id}'")
        self._refresh_outputs()
        return ok

    def set_engine_on(self, obj_id: str, on: bool) -> None:
        self.st.engine_on[self._need(obj_id)] = bool(on)

    def set_enabled(self, obj_id: str, on: bool) -> None:
        i = self._need(obj_id)
        if on and self.kind[i] == KIND_NONE:
            self._event_warning(obj_id, f"'{obj_id}' has no usable path and stays disabled")
            return
        self.st.enabled[i] = bool(on)

    # ------------------------------------------------------------------ helpers
    def _warn(self, source: str, message: str) -> None:
        log.warning(message)
        self._warnings.append((source, message))


def _half_extents(o: TrafficVehicle | Pedestrian | ODVehicle) -> tuple[float, float]:
    if isinstance(o, Pedestrian):
        return PEDESTRIAN_HALF
    path = o.model_path.lower()
    return TRUCK_HALF if any(w in path for w in ("truck", "bus", "lorry")) else CAR_HALF


def _min_dist(o: TrafficVehicle | Pedestrian | ODVehicle) -> float:
    if isinstance(o, ODVehicle):
        return min(1.0, o.distance_from_path_m or 1.0)
    return o.min_distance_from_path_m if o.min_distance_from_path_m is not None else 1.0


def _max_dist(o: TrafficVehicle | Pedestrian | ODVehicle) -> float:
    if isinstance(o, ODVehicle):
        return o.distance_from_path_m or 10.0
    return max(_min_dist(o), o.max_distance_from_path_m if o.max_distance_from_path_m is not None else 10.0)
