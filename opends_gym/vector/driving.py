"""A driving task with traffic for a native batch (`OpenDS/DrivingTask-v0`, MotorwayTask first).

Why: tasks with traffic (MotorwayTask: 41 cars on a road network, trigger boxes) ran one env
per process. Here N worlds of one task step together (`core.BatchCore`): the ego cars through
the LCT's compiled car model (`ego`), the traffic cars through the single env's own compiled
kernels (`sim.traffic.motion`, over all envs' cars at once, see `NetTraffic`), the lanes on
the task's route through `route`, the triggers through `triggers.TriggerBatch`, and contacts
with traffic and static obstacles as `World._contacts` counts them (an obstacle stops the car,
`FastVehicle.stop_at_contact`). Reward, ends and info are `OpenDSEnv`'s defaults. Worlds
whose ego car no traffic car has seen since their reset take their cars' places from one
shared history instead of stepping them (`traffic_history`: the same floats, ~6 ns per car
and physics step instead of ~100).

Supported: what MotorwayTask and tasks like it use. Traffic cars on their own waypoint paths
or on a road network without random forks (so every seed places and moves the cars alike, as
in the corpus tasks); lanes as X bands or along the ego's route; collideWith triggers whose
actions are logging, reaction timers or stimuli (`setMotorwayTaskStimulus`, counted as the
single env's `stimulus` events); pressKey triggers whose key no batched action presses.
Anything else is refused when the batch is built, with a one-line error naming the feature.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

from ..envs.base import LANE_KEEPING_OFFSET_M
from ..jit import kernel
from ..sim.traffic.legs import KIND_NET, KIND_OWN
from ..sim.traffic.motion import ARRIVED, N_WORK, NOTHING_LIVE, WAIT_OVER, WAITS_OVER, advance_carrots, drive
from ..sim.traffic.state import Specs
from ..sim.triggers.core import CompiledAction
from ..sim.world import TRAFFIC_REACH_Y_M
from . import ego
from .actions import BatchControls
from .core import BatchCore
from .driving_step import TIME_MISMATCH, _shared_range, _worlds_range, contacts, history_rows, step_shared, step_worlds
from .kernels import CHUNK_ENVS, box_centre, ego_features_row, volume_fires
from .platoon_step import _lead_range
from .route import locate_route, record_route, route_tables
from .traffic import FlatTraffic, _Legs
from .traffic_history import TrafficHistory
from .triggers import TriggerBatch

STIMULUS_ACTIONS = frozenset({"setMotorwayTaskStimulus"})  # logged as `stimulus` events by the single env (no task handler)


class NetTraffic(FlatTraffic):
    """`FlatTraffic` plus road-network cars (without random forks): each world steps through
    `motion.step_objects`, the rare leg ends that need Python (waits, end points, jumps) run
    the single env's `LegLogic`. With `dt` (the batch's physics step), the worlds that
    follow the `TrafficHistory` (`shared`, at entry `kw`) keep only their cars' positions,
    headings, speeds and enabled flags in their rows (`sync` fills the rest)."""

    def __init__(self, tm: Any, n: int, ego_length_m: float, ego_half: tuple[float, float], dt: float = 0.0) -> None:
        if tm.lights is not None:
            raise ValueError("the native batch does not support traffic lights")
        if not tm.is_car.all():
            raise ValueError("the native batch does not support pedestrians")
        if np.any((tm.kind != KIND_OWN) & (tm.kind != KIND_NET)):
            raise ValueError("the native batch does not support OpenDRIVE traffic routes")
        if tm._any_seg_prio or tm._any_seg_nb:
            raise ValueError("the native batch does not support giveWayTo segments or segments with neighbours (passing lanes)")
        if np.any(tm.sp.never_faster) or np.any(tm._stuck_reset):
            raise ValueError("the native batch does not support neverFasterThanSteeringCar or resetWhenStuck")
        if any(tm.preferred):
            raise ValueError("the native batch does not support preferred segments")
        net = tm.network
        if net is not None and any(len(v) > 1 for v in net.outgoing.values()):
            raise ValueError("the native batch does not support road networks with random forks (a waypoint with several next segments)")
        self.n, self.c = n, len(tm.ids)
        tm.world.reset(seed=0)  # the cars as a reset places them
        self.tm = tm
        self.paths = tm.paths
        self.st0 = tm.st.copy()
        self.st = self.st0.tile(n)
        self.sp = Specs(**{f.name: np.tile(getattr(tm.sp, f.name), n) for f in fields(Specs) if f.init})
        self.work = np.zeros((N_WORK, n * self.c))
        self.flags = np.zeros(n * self.c, dtype=np.int64)
        self.no_lights = np.zeros(1, dtype=bool)
        self.legs = _Legs(tm, self.st, n)
        self.legs.network = tm.network
        self.net = tm._net_table
        self.quiet = np.tile(tm._quiet_cars, n)
        self.ego = np.zeros((3, n))  # each world's ego car: x, z, speed (no car here watches the ego's speed)
        self.codes = np.zeros(n, dtype=np.int64)
        self.brake = np.zeros(n * self.c, dtype=bool)
        self.turn = np.zeros(n * self.c, dtype=np.int64)
        self.all_rows = np.ones(self.c, dtype=bool)
        self.car_rows = np.ones(n * self.c, dtype=bool)
        self.parallel = n > CHUNK_ENVS
        self.half = np.tile(tm.half_extents, (n, 1))
        self.ego_length = ego_length_m
        self.ego_reach = math.hypot(*ego_half)
        self.reach = self.ego_reach + np.hypot(self.half[:, 0], self.half[:, 1])
        self.hitting = np.zeros(n * self.c, dtype=bool)
        self.drive_pos: np.ndarray | None = None  # (`TrafficHistory`: where the cars were at `drive`)
        # the worlds no traffic car has seen the ego of since their reset follow one world's history
        self.history = TrafficHistory(NetTraffic(tm, 1, ego_length_m, ego_half), dt) if dt > 0.0 else None
        if self.history is not None and not all(np.array_equal(x, y[0], equal_nan=True) for x, y in zip(
                (self.st0.f, self.st0.i, self.st0.b, self.st0.pos), self.history.arrays())):  # fmt: skip
            raise RuntimeError("native DrivingTask batch: a reset places the cars differently each time (a bug)")
        self.shared = np.zeros(n, dtype=bool)
        self.kw = np.zeros(n, dtype=np.int64)

    def reset_envs(self, idx: np.ndarray) -> None:
        """The cars of the envs idx as a reset places them (the same for every seed: no random
        fork on the network, checked when the batch is built); they follow the history again."""
        self.reset_rows(idx, self.st0)
        if self.history is not None:
            self.shared[idx] = True
            self.kw[idx] = 0

    def sync(self, whole: bool = False) -> None:
        """The rows of the worlds that follow the history: the int and bool rows (which the
        nearby-vehicle slots read: brake lights, turn signals), or everything (`whole`)."""
        if self.history is not None and self.shared.any():
            st = self.st
            h = self.history
            history_rows(st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, self.c, self.shared, self.kw, h.hf, h.hi, h.hb,
                         h.hpos, h.hend, h.hlight, h.hext, whole)  # fmt: skip

    def slots(self, k: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray) -> np.ndarray:
        self.sync()
        return super().slots(k, x, z, yaw, u)

    def step(self, live_env: np.ndarray, dt: float, t_env: np.ndarray, ex: np.ndarray, ez: np.ndarray) -> None:
        """`TrafficManager.step` for the cars of the envs `live_env`: each world's
        `motion.step_objects` (`driving_step.step_worlds`), then, for the worlds that stopped
        for Python, the rest of the step as `TrafficManager._step_with_events` does it."""
        st, c = self.st, self.c
        pf, pp, pi = self.paths.arrays()
        t = np.ascontiguousarray(t_env, dtype=np.float64)
        self.ego[0], self.ego[1] = ex, ez
        args: tuple[Any, ...] = (st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, self.sp.packed, pf, pp, pi, t, self.ego,
                                 dt, self.work, self.flags, self.no_lights, self.brake, self.turn, self.net, self.quiet, c, live_env,
                                 self.codes, self.car_rows)  # fmt: skip
        h = self.history
        if h is None:
            left = step_worlds(*args) if self.parallel else _worlds_range(0, self.n, *args)
        else:
            follow = live_env & self.shared
            if follow.any():
                h.extend_to(int(self.kw[follow].max()) + 1)
            args += (self.shared, self.kw, h.length, *h.arrays())
            left = step_shared(*args) if self.parallel else _shared_range(0, self.n, *args)
            if left and np.any(self.codes == TIME_MISMATCH):
                raise RuntimeError("native DrivingTask batch: a world's time is not its traffic history's (a bug)")
        if left:
            for w in np.flatnonzero((self.codes != 0) & (self.codes != NOTHING_LIVE)).tolist():
                self._with_events(w, int(self.codes[w]), dt, t)

    def _with_events(self, w: int, code: int, dt: float, t: np.ndarray) -> None:
        """`TrafficManager._step_with_events` for world w (its rows of the flat state, as views)."""
        st, c = self.st, self.c
        a, z = w * c, (w + 1) * c
        f, i, b, pos, work, flags = st.f[:, a:z], st.i[:, a:z], st.b[:, a:z], st.pos[a:z], self.work[:, a:z], self.flags[a:z]
        sp = self.sp.packed[:, a:z]
        tw = t[w : w + 1]
        pf, pp, pi = self.paths.arrays()
        legs = self.legs
        legs.t_s = float(t[w])
        if code == WAITS_OVER:
            for k in np.flatnonzero(flags & WAIT_OVER).tolist():
                legs._finish_wait(a + k)
            pf, pp, pi = self.paths.arrays()
            code = advance_carrots(f, i, b, pos, sp, pf, pp, pi, c, self.all_rows, tw, dt, work, flags)
        if code > 0:
            for k in np.flatnonzero(flags & ARRIVED).tolist():
                legs._arrive(a + k)
            pf, pp, pi = self.paths.arrays()
        if self.drive_pos is not None:
            self.drive_pos[:] = pos
        drive(f, i, b, pos, st.end_xz[a:z], st.light_xz[a:z], st.ext_cmd[a:z], sp, pf, pp, pi, c, self.all_rows, self.ego[:, w : w + 1],
              dt, work, flags, code > 0, self.no_lights)  # fmt: skip


class AnyVolumes(TriggerBatch):
    """`TriggerBatch` whose contact test checks every trigger volume (a task's volumes may lie
    close together: MotorwayTask's start-recording and enter-motorway boxes)."""

    spaced = False

    def touching(self, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, shift: float, rows: np.ndarray,
                 t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        out = np.zeros((len(x), len(self.vols)), dtype=bool)
        if len(self.vols) and _touch_all(x, z, yaw, shift, rows, self.car_half[0], self.car_half[1], self.vols, self.vol_triggers, t,
                                         self.locks, out):  # fmt: skip
            env, vol = np.nonzero(out)
            return env, vol
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)


@kernel
def _touch_all(x: np.ndarray, z: np.ndarray, yaw: np.ndarray, shift: float, rows: np.ndarray, hx: float, hz: float, vols: np.ndarray,
               vol_triggers: np.ndarray, t: np.ndarray, locks: np.ndarray, out: np.ndarray) -> int:  # fmt: skip
    """`kernels.touch_triggers` over every volume: out[e, j] where env e's car box overlaps
    volume j, which has a trigger not locked at time t; the number of such pairs."""
    count = 0
    for e in range(len(x)):
        if rows[e]:
            bx, bz = box_centre(x[e], z[e], yaw[e], shift)
            for j in range(vols.shape[0]):
                if volume_fires(e, j, bx, bz, yaw[e], hx, hz, vols, vol_triggers, t[e], locks):
                    out[e, j] = True
                    count += 1
    return count


class DrivingTaskBatch(BatchCore):
    """N envs of one `DrivingTaskEnv` task; see the module docstring."""

    handled_actions = STIMULUS_ACTIONS | frozenset({"setupLaneChangeReactionTimer", "setupBrakeReactionTimer"})
    trace_columns: tuple[str, ...] = ("x_m", "z_m", "speed_mps", "steering", "accelerator", "brake", "headway_s", "ttc_s", "gap_m",
                                      "lead_speed_mps", "lateral_m", "lane_index", "lane_offset_m")  # fmt: skip
    needs_distance = True
    has_traffic = True
    guide_kinds = ("lanes", "route")
    trigger_class = AnyVolumes
    parallel_kernels = True  # the traffic kernel runs chunks of worlds on numba's threads: one shard by default

    @property
    def parallel(self) -> bool:
        """Whether the traffic kernel runs its chunks on numba's threads (`env.NativeVectorEnv`
        turns it off for shards stepped in Python threads)."""
        return bool(self.traffic.parallel)

    @parallel.setter
    def parallel(self, value: bool) -> None:
        self.traffic.parallel = value

    def __init__(self, template: Any, n: int, record_metrics: bool = True) -> None:
        w = template.world
        if w.traffic is None:
            raise ValueError("the native DrivingTask batch needs a task with traffic")
        if template.config.reward_speed_weight:
            raise ValueError("the native batch does not support reward_speed_weight")
        self._template_action = template.act_type
        super().__init__(template, n, record_metrics)
        g = self.guide
        self.on_route = g.kind == "route"
        if self.on_route:
            self.route = route_tables(g)
        self.hint = np.zeros(n, dtype=np.int64)
        self.s_route = np.zeros(n)
        self.heading = np.full(n, float(getattr(g, "road_heading", 0.0)))
        self.first = np.zeros(n, dtype=bool)
        spec = w.ego.spec
        self.traffic = NetTraffic(w.traffic, n, spec.length_m, self.car_half, self.dt)
        self._half_len = np.ascontiguousarray(self.traffic.half[:, 1])
        self.lead_j = np.full(n, -1, dtype=np.int64)
        self.lead_gap = np.zeros(n)
        self.lead_v = np.zeros(n)
        self.gap_m = np.full(n, np.inf)
        self.lead_speed_mps = np.full(n, np.nan)
        self.lateral_m, self.lane_index, self.lane_offset_m = self.lat, self.lane, self.offset
        self.stimuli = np.zeros(n, dtype=np.int64)
        self.prev_x = np.zeros(n)
        self.prev_z = np.zeros(n)
        self._obstacles(w)
        left, right = g.road_edges_m
        margin = template.config.off_road_margin_m
        self.off_left, self.off_right = left + margin, right - margin

    def _obstacles(self, w: Any) -> None:
        """The static obstacles the car can reach on flat ground (`SceneObjects.overlapping_with_room`)."""
        y = w.ego.state.y
        height = w.ego.spec.height_m
        obs = []
        for o in w.objects.objects:
            if not o.collidable or o.is_trigger:
                continue
            lo, hi = o.y_range()
            if hi < y - 0.5 or lo > y + height:
                continue
            obs.append((o.position[0], o.position[2], o.yaw, o.half[0], o.half[2]))
        self.obs = np.array(obs, dtype=np.float64).reshape(-1, 5)
        self.obs_hitting = np.zeros((self.n, len(obs)), dtype=bool)
        self.stops_car = bool(w.config.collision_stops_car)
        # `TrafficManager.colliding_with`'s reach: each car's half diagonal plus the ego box's (CPython's hypot)
        tm = w.traffic
        self.reach = np.tile(tm._half_diag + math.hypot(*self.car_half), self.n)
        self.new_hits = np.zeros(self.n, dtype=np.int64)
        self.stop = np.zeros(self.n, dtype=bool)

    def _pressable_keys(self) -> frozenset[str] | None:
        key = getattr(self._template_action, "reaction_key", None)
        return frozenset({key}) if key is not None else frozenset()

    # ------------------------------------------------------------------ reset
    def _reset_task(self, idx: np.ndarray) -> None:
        self.traffic.reset_envs(idx)
        self.obs_hitting[idx] = False
        self.stimuli[idx] = 0
        self.hint[idx] = 0
        self.first[:] = False
        self.first[idx] = True
        if self.on_route:  # OpenDSEnv.reset: guide.reset(), then `_last_s` = guide.locate(...)
            seg, xz, ps, sl = self.route
            locate_route(self.s.x, self.s.z, self._mask(idx), seg, xz, ps, sl, self.hint, self.s_route)
            self.last_s[idx] = self.s_route[idx]
        else:
            self.last_s[idx] = super()._s_along(self.s.z[idx])

    def _s_along(self, z: np.ndarray) -> np.ndarray:
        if not self.on_route:
            return super()._s_along(z)
        return self.s_route.copy() if len(z) == self.n else np.zeros(len(z))  # (reset rows: `_reset_task` sets them)

    # ------------------------------------------------------------------ lanes
    def _record_row(self, rows: np.ndarray, first: bool) -> None:
        if not self.on_route:
            return super()._record_row(rows, first)
        s = self.s
        self._lead_measures()
        rl, g = self.rl, self.guide
        seg, xz, ps, sl = self.route
        firsts = self.first if first else np.zeros(self.n, dtype=bool)
        record_route(s.x, s.z, rows, firsts, seg, xz, ps, sl, self.hint, np.asarray(g.lane_laterals_m, dtype=np.float64),
                     g.lane_width_m / 2.0, LANE_KEEPING_OFFSET_M, self.s_route, self.heading, self.lat, self.lane, self.offset, rl["n"],
                     rl["mean"], rl["m2"], self.prev_x, self.prev_z, rl["dist"], rl["area"])  # fmt: skip
        self._write_trace(rows, first)

    # ------------------------------------------------------------------ world
    def _physics_step(self, live: np.ndarray, c: BatchControls) -> None:
        """`World.step_clipped` for the envs `live`: car, traffic, contacts (an obstacle stops
        the car after the trigger boxes it touches are found), triggers, timers."""
        self.step_count += live
        self.t = self.step_count * self.dt
        s = self.s
        px, pz = s.x.copy(), s.z.copy()
        ego.step(self.p, s, self.dt, c.steer, c.gas, c.brake, live)
        self.traffic.step(live, self.dt, self.t, s.x, s.z)
        cx = s.x - self.car_shift * np.sin(s.yaw)
        cz = s.z - self.car_shift * np.cos(s.yaw)
        tr = self.traffic
        st = tr.st
        contacts(live, cx, cz, s.yaw, s.y, self.car_half[0], self.car_half[1], st.pos, st.yaw, st.enabled, tr.half, self.reach,
                 TRAFFIC_REACH_Y_M, tr.c, tr.hitting, self.obs, self.obs_hitting, self.new_hits, self.stop)  # fmt: skip
        self.collisions += self.new_hits
        env, vol = self.trig.touching(s.x, s.z, s.yaw, self.car_shift, live & ~self.trig.paused, self.t)
        if self.stops_car and self.stop.any():  # FastVehicle.stop_at_contact: back to the last free position, at rest
            stop = self.stop
            s.x = np.where(stop, px, s.x)
            s.z = np.where(stop, pz, s.z)
            for a in (s.u, s.v, s.r):
                a[stop] = 0.0
        if env.size:
            self.trig.fire(self.t, env, vol, self._run_action)
        polled = live & ~self.trig.paused
        self.timers.update(polled, self.t, s.x, s.z, s.u, s.steer_in, s.brake_in, self.trig.started_at)

    def _lead_measures(self) -> None:
        s, st = self.s, self.traffic.st
        args = (s.x, s.z, s.yaw, s.u, st.pos, st.yaw, st.speed, st.enabled, self._half_len, self.traffic.c, self.traffic.ego_length,
                self.lead_j, self.lead_gap, self.lead_v, self.headway, self.ttc)  # fmt: skip
        _lead_range(0, self.n, *args)  # (serial: a pass this short lost more to waking numba's threads than it gained)
        fin = (self.lead_j >= 0) & np.isfinite(self.lead_gap)
        self.gap_m = np.where(fin, self.lead_gap, np.inf)
        self.lead_speed_mps = np.where(fin, self.lead_v, np.nan)

    def vehicle_slots(self, k: int) -> np.ndarray | None:
        s = self.s
        return self.traffic.slots(k, s.x, s.z, s.yaw, s.u)

    def observation(self, k: int, size: int) -> np.ndarray | None:
        s = self.s
        out = np.empty((self.n, size), dtype=np.float32)
        _ego_features(out, s.u, s.yaw, self.heading, self.offset, self.lat, self.lane, s.steer_in, s.r)
        if k:
            vehicles = self.vehicle_slots(k)
            assert vehicles is not None
            out[:, 7 : 7 + vehicles.shape[1]] = vehicles
        return out

    # ------------------------------------------------------------------ actions, outputs
    def _on_action_rows(self, es: np.ndarray, act: CompiledAction, trigger: int) -> None:
        if act.name in STIMULUS_ACTIONS:
            self.stimuli[es] += 1
            return
        super()._on_action_rows(es, act, trigger)

    def _task_terminated(self) -> np.ndarray:
        """Off the road (`OpenDSEnv._off_road_at`, on_road_exit='terminate')."""
        return (self.lat > self.off_left) | (self.lat < self.off_right)

    def _reward(self, info: dict[str, np.ndarray], terminated_task: np.ndarray) -> np.ndarray:
        return info["progress_m"] - 0.1 * np.abs(info["lateral_offset_m"]) - 10.0 * info["new_collisions"].astype(np.float64)

    def _task_info(self, info: dict[str, np.ndarray]) -> None:
        g = self.guide
        info["lanes_known"] = (self.last_s >= g.join_s_m) & bool(g.lanes_known)

    def _load_episode(self, e: int, columns: np.ndarray | None) -> None:
        w = self.template.world
        w.events.clear()
        for _ in range(int(self.stimuli[e])):
            w.events.emit(0.0, "stimulus", "setMotorwayTaskStimulus")
        self.template._reset_rows = []


def _ego_features(out: np.ndarray, u: np.ndarray, yaw: np.ndarray, heading: np.ndarray, offset: np.ndarray, lat: np.ndarray,
                  lane: np.ndarray, steer: np.ndarray, r: np.ndarray) -> None:  # fmt: skip
    """`kernels.ego_features` with each env's own road heading."""
    _ego_rows(out, u, yaw, heading, offset, lat, lane, steer, r)


@kernel
def _ego_rows(out: np.ndarray, u: np.ndarray, yaw: np.ndarray, heading: np.ndarray, offset: np.ndarray, lat: np.ndarray,
              lane: np.ndarray, steer: np.ndarray, r: np.ndarray) -> None:  # fmt: skip
    for e in range(len(u)):
        ego_features_row(out, e, u[e], yaw[e], heading[e], offset[e], lat[e], lane[e], steer[e], r[e])
