"""`BatchCore`: N worlds of one task stepped together, the batched `OpenDSEnv.step` loop.

Why: the native batch runs the single env's physics step (World.step) and policy step
(OpenDSEnv.step: action repeat, early stop, trace row, task hook, info, reward, end) for
all envs with one numpy array per state variable. Task batches (`lct`, `platoon`)
subclass it and fill in the hooks the single env's task classes have (`_reset_task`,
`_on_physics_step`, `_stimulus`, `_reward`, `_task_terminated`, `_episode_metrics`).
A private single env of the same id and options (`template`) supplies the task, its
constants and, at the end of an episode, scores the episode's trace with its own
`episode_metrics()` (rare, per env).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium.utils import seeding

from ..envs.base import LANE_KEEPING_OFFSET_M, OpenDSEnv
from ..sim.triggers.core import CompiledAction
from . import ego
from .actions import BatchActions, BatchControls
from .kernels import record_lanes
from .lanes_known import lanes_known_rows
from .timers import KINDS, TimerBatch
from .trace import TraceRing
from .triggers import TriggerBatch


class BatchCore:
    """State and physics of N envs; see the module docstring."""

    handled_actions: frozenset[str] = frozenset({"setupLaneChangeReactionTimer", "setupBrakeReactionTimer", "manipulateObject"})
    trace_columns: tuple[str, ...] = ("x_m", "z_m", "speed_mps", "steering")
    needs_distance = False  # the base running mean deviation (the LCT replaces it)
    has_traffic = False  # `_traffic_step` and `_traffic_hits` do something
    parallel_kernels = False  # its step kernels run chunks of envs on numba's threads (one shard by default)
    trigger_class: type[TriggerBatch] = TriggerBatch
    guide_kinds: tuple[str, ...] = ("lanes",)  # the `RoadGuide` kinds the batch measures lanes on

    def __init__(self, template: OpenDSEnv, n: int, record_metrics: bool = True) -> None:
        self.template: Any = template
        self.n = n
        cfg = template.config
        self.config = cfg
        w = template.world
        self.world = w
        self.guide = template.guide
        if self.guide.kind not in self.guide_kinds:
            raise ValueError(
                f"the native batch of this task needs a road guide of kind {' or '.join(self.guide_kinds)}, not {self.guide.kind!r}"
            )
        self.dt = w.dt_s
        self.repeat = cfg.action_repeat
        self.p = ego.EgoParams.from_world(w)
        self.s = ego.EgoArrays.zeros(n)
        spec = w.ego.spec
        self.car_half = (0.5 * spec.width_m, 0.5 * spec.length_m)
        self.car_shift = 0.5 * spec.wheelbase_m - spec.cog_to_front_m
        self.trig = self.trigger_class(n, w, self.handled_actions, self.car_half, spec.height_m, self._pressable_keys())
        self.bands = tuple((b.x_min, b.x_max) for b in w.road.lanes)
        self.timers = TimerBatch(n, self.bands)
        lane_ids = tuple(b.id for b in w.road.lanes)
        for trig in self.trig.triggers:
            for act in trig.actions:
                if act.name in KINDS:
                    self.timers.add_spec(act.counter, act.name, act.args, lane_ids)
        self.actions = BatchActions(cfg.action, n)
        self.record_metrics = record_metrics
        max_steps = int(math.ceil(cfg.max_episode_s / self.dt)) + 2 * self.repeat
        self.ring = TraceRing(n, self.trace_columns, max_steps) if record_metrics else None
        self.rngs: list[np.random.Generator | None] = [None] * n
        self.draws = np.zeros(n, dtype=np.int64)  # world seeds of resets in compiled code, drawn at the next `_world_seed`
        self.step_count = np.zeros(n, dtype=np.int64)
        self.t: np.ndarray = np.zeros(n)
        self.collisions = np.zeros(n, dtype=np.int64)
        self.collisions_seen = np.zeros(n, dtype=np.int64)
        self.last_s = np.zeros(n)
        self.reaction_cursor = np.zeros(n, dtype=np.int64)
        self.lat = np.zeros(n)
        self.lane = np.zeros(n, dtype=np.int64)
        self.centres = np.asarray(self.guide.lane_laterals_m, dtype=np.float64)
        self.offset = np.zeros(n)
        self.headway = np.full(n, np.inf)
        self.ttc = np.full(n, np.inf)
        self.rl = {k: np.zeros(n) for k in ("n", "mean", "m2", "area", "dist")}
        self.start_z = float(w.task.start_pose.position_m[2])
        self.prev_x = np.zeros(n)
        self.prev_z = np.zeros(n)
        self.progress = np.zeros(n)
        self.new_collisions = np.zeros(n, dtype=np.int64)

    # ------------------------------------------------------------------ task hooks
    def _pressable_keys(self) -> frozenset[str] | None:
        """The keyboard keys the batch's action type can press (None: pressKey triggers are refused)."""
        return None

    def _reset_task(self, idx: np.ndarray) -> None:
        """After the world rows are reset, before the first trace row."""

    def _traffic_step(self, rows: np.ndarray) -> None:
        """Move the traffic of the envs `rows` (World.step, after the ego car)."""

    def _traffic_hits(self, box: tuple[np.ndarray, ...], rows: np.ndarray) -> np.ndarray:
        """New contacts of the ego boxes with traffic, per env (count)."""
        return np.zeros(self.n, dtype=np.int64)

    def _lead_measures(self) -> None:
        """Fill `headway` and `ttc` for the current positions (no traffic: inf)."""

    def _lead_measures_of(self, rows: np.ndarray | None) -> None:
        """`_lead_measures` when only the envs `rows` (a mask; None: any) moved since the last
        call (a reset: the others' measures stand)."""
        self._lead_measures()

    def _on_action(self, e: int, act: CompiledAction, trigger: int) -> None:
        raise ValueError(f"action {act.name} is not handled by {type(self).__name__}")

    def _on_physics_step(self, rows: np.ndarray, k: int, c: BatchControls) -> None:
        """After each physics step's trace row (the single env's `_on_physics_step`)."""

    def observation(self, k: int, size: int) -> np.ndarray | None:
        """The kinematics observation in one compiled pass, for batches that have one (None:
        `shards.observe` assembles it from `vehicle_slots` and `_stimulus`)."""
        return None

    def _stimulus(self) -> np.ndarray:
        return np.zeros((self.n, 0))

    def vehicle_slots(self, k: int) -> np.ndarray | None:
        """The kinematics observation's K nearest-vehicle slots (None: no traffic, all zeros)."""
        return None

    def _reward(self, info: dict[str, np.ndarray], terminated_task: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _task_terminated(self) -> np.ndarray:
        return np.zeros(self.n, dtype=bool)

    def _task_info(self, info: dict[str, np.ndarray]) -> None:
        """Add or override info arrays."""

    def _load_episode(self, e: int, columns: np.ndarray | None) -> None:
        """Put env e's task state into the template before `episode_metrics()` (its trace is
        loaded; `columns`: the ring's columns of the episode, when read already)."""

    # ------------------------------------------------------------------ reset
    def reset_rows(self, idx: np.ndarray, seeds: list[int | None] | None) -> None:
        """`OpenDSEnv.reset` for the envs `idx`: seeds (None keeps the env's generator)."""
        for j, e in enumerate(idx.tolist()):
            seed = seeds[j] if seeds is not None else None
            if seed is not None or self.rngs[e] is None:
                self.rngs[e], _ = seeding.np_random(seed)
                self.draws[e] = 0
            self._world_seed(e)
        ego.reset_rows(self.p, self.s, idx)
        self.trig.reset_rows(idx)
        self.timers.reset_rows(idx)
        self.actions.reset_rows(idx)
        self.step_count[idx] = 0
        self.t[idx] = 0.0
        self.collisions[idx] = 0
        self.collisions_seen[idx] = 0
        self.reaction_cursor[idx] = 0
        self.progress[idx] = 0.0
        self.new_collisions[idx] = 0
        for v in self.rl.values():
            v[idx] = 0.0
        self.last_s[idx] = self._s_along(self.s.z[idx])
        self._reset_task(idx)
        self._record_row(self._mask(idx), first=True)

    def _world_seed(self, e: int) -> None:
        rng = self.rng(e)
        rng.integers(0, 2**31 - 1)  # World.reset(seed=...): the batch's worlds use no randomness

    def rng(self, e: int) -> np.random.Generator:
        """Env e's generator, after the world seeds that compiled resets left to draw (`draws`:
        their values are not used, so they are drawn when the generator is next read)."""
        rng = self.rngs[e]
        assert rng is not None
        for _ in range(int(self.draws[e])):
            self._draw_world_seed(e, rng)
        self.draws[e] = 0
        return rng

    def _draw_world_seed(self, e: int, rng: np.random.Generator) -> None:
        """The draws of one reset's world seed from env e's generator `rng` (`rng`, `draws`)."""
        rng.integers(0, 2**31 - 1)  # World.reset(seed=...): the batch's worlds use no randomness

    def _mask(self, idx: np.ndarray) -> np.ndarray:
        m = np.zeros(self.n, dtype=bool)
        m[idx] = True
        return m

    def _s_along(self, z: np.ndarray) -> np.ndarray:
        return -self.guide.sign * (z - self.guide.start_xz[1])

    # ------------------------------------------------------------------ step
    def step_rows(self, actions: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """One policy step of the envs `rows`: (reward, terminated, truncated, info)."""
        c = self.actions.convert(actions, rows)
        self._physics_steps(rows.copy(), c)
        s_now = self._s_along(self.s.z)
        self.progress = np.where(rows, s_now - self.last_s, 0.0)
        self.last_s = np.where(rows, s_now, self.last_s)
        self.new_collisions = np.where(rows, self.collisions - self.collisions_seen, 0)
        self.collisions_seen = self.collisions.copy()
        info = self.info()
        task_end = self._task_terminated()
        reward = self._reward(info, task_end)
        terminated = self._terminated(self.new_collisions, task_end)
        truncated = ~terminated & (self.t >= self.config.max_episode_s - 1e-9)
        return reward, terminated & rows, truncated & rows, info

    def _physics_steps(self, live: np.ndarray, c: BatchControls) -> None:
        """The policy step's physics steps (action repeat) of the envs `live`, each followed by
        its trace row and task hook; an env stops early when its episode ends."""
        for k in range(self.repeat):
            self._physics_step(live, c)
            self._record_row(live, first=False)
            self._on_physics_step(live, k, c)
            live &= ~self._stop_early()
            if not live.any():
                break

    def _physics_step(self, live: np.ndarray, c: BatchControls) -> None:
        self.step_count += live
        self.t = self.step_count * self.dt
        ego.step(self.p, self.s, self.dt, c.steer, c.gas, c.brake, live)
        self._traffic_step(live)
        s = self.s
        if self.has_traffic:  # the car's box is centred half a wheelbase ahead of its reference point
            cx = s.x - self.car_shift * np.sin(s.yaw)
            cz = s.z - self.car_shift * np.cos(s.yaw)
            self.collisions += self._traffic_hits((cx, cz, s.yaw), live)
        env, vol = self.trig.touching(s.x, s.z, s.yaw, self.car_shift, live & ~self.trig.paused, self.t)
        if env.size:
            self.trig.fire(self.t, env, vol, self._run_action)
        polled = live & ~self.trig.paused
        self.timers.update(polled, self.t, s.x, s.z, s.u, s.steer_in, s.brake_in, self.trig.started_at)

    def _run_action(self, es: np.ndarray, act: CompiledAction, trigger: int) -> None:
        """A trigger's action for the envs `es` (those whose trigger fired)."""
        if act.name in KINDS:
            es = es[self.trig.started[es]]
            if es.size:
                s = self.s
                self.timers.setup(es, act.counter, self.t[es], s.x[es], s.z[es], s.u[es], self.trig.started_at[es])
            return
        self._on_action_rows(es, act, trigger)

    def _on_action_rows(self, es: np.ndarray, act: CompiledAction, trigger: int) -> None:
        """A task action for the envs `es`; by default `_on_action` for each of them."""
        for e in es.tolist():
            self._on_action(e, act, trigger)

    def _record_row(self, rows: np.ndarray, first: bool) -> None:
        """`OpenDSEnv._record_row` for the envs `rows` (trace row, running lateral measures)."""
        s = self.s
        self._lead_measures_of(rows if first else None)
        rl, g = self.rl, self.guide
        record_lanes(s.x, s.z, rows, first, g.sign, self.centres, g.lane_width_m / 2.0, LANE_KEEPING_OFFSET_M, self.lat, self.lane,
                     self.offset, rl["n"], rl["mean"], rl["m2"], self.needs_distance, self.prev_x, self.prev_z, rl["dist"],
                     rl["area"])  # fmt: skip
        self._write_trace(rows, first)

    def _write_trace(self, rows: np.ndarray, first: bool) -> None:
        """The trace row of the envs `rows` into the ring (a reset's first row restarts it)."""
        if self.ring is not None:
            values = self._trace_values()
            if first:
                idx = np.flatnonzero(rows)
                self.ring.reset_rows(idx, {k: v[idx] for k, v in values.items()})
            else:
                self.ring.write(values, None if rows.all() else rows)

    def _trace_values(self) -> dict[str, np.ndarray]:
        s = self.s
        out = {"x_m": s.x, "z_m": s.z, "speed_mps": s.u, "steering": s.steer_in}
        extra = {"accelerator": s.gas_in, "brake": s.brake_in, "headway_s": self.headway, "ttc_s": self.ttc}
        extra |= {k: getattr(self, k) for k in self.trace_columns if k not in out and k not in extra}
        return {k: out.get(k, extra.get(k)) for k in self.trace_columns}  # type: ignore[misc]

    def _stop_early(self) -> np.ndarray:
        return self._terminated(self.collisions - self.collisions_seen, self._task_terminated())

    def _terminated(self, new_collisions: np.ndarray, task_end: np.ndarray) -> np.ndarray:
        out = self.trig.paused | task_end
        if self.config.terminate_on_collision:
            out = out | (new_collisions > 0)
        return out

    # ------------------------------------------------------------------ info
    def sdlp(self) -> np.ndarray:
        n = self.rl["n"]
        return np.where(n >= 2, np.sqrt(self.rl["m2"] / np.maximum(n, 1.0)), 0.0)

    def info(self) -> dict[str, np.ndarray]:
        new = self.timers.n_results > self.reaction_cursor
        result = np.where(new, self.timers.last_result, 0.0)
        rt = np.where(new, self.timers.last_rt, 0.0)
        self.reaction_cursor = self.timers.n_results.copy()
        dist = self.rl["dist"]
        info = {
            "sim_time_s": self.t.copy(),
            "speed_kmh": self.s.u * 3.6,
            "lateral_offset_m": self.offset.copy(),
            "lane_index": self.lane.copy(),
            "fuel_used_l": self.s.fuel_used.copy(),
            "collisions": self.collisions.copy(),
            "reaction_result": result,
            "reaction_time_s": rt,
            "mean_deviation_m": np.where(dist > 0, self.rl["area"] / np.where(dist > 0, dist, 1.0), 0.0),
            "sdlp_m": self.sdlp(),
            "headway_s": self.headway.copy(),
            "ttc_s": self.ttc.copy(),
            "lanes_known": lanes_known_rows(self.guide, self.last_s),
            "resets": np.zeros(len(self.t), dtype=np.int64),  # (on_road_exit="terminate" only: never reset)
            "reset_time_s": np.zeros(len(self.t)),
            "progress_m": self.progress.copy(),
            "new_collisions": self.new_collisions.copy(),
        }
        self._task_info(info)
        return info

    def episodes_metrics(self, es: list[int]) -> list[tuple[int, dict[str, float]]]:
        """`episode_metrics` of the envs `es` (their traces read together)."""
        if self.ring is None:
            raise RuntimeError("episode metrics were switched off (record_metrics=False)")
        columns = self.ring.columns_of(es)
        return [(e, self.episode_metrics(e, columns[e])) for e in es]

    def episode_metrics(self, e: int, columns: np.ndarray | None = None) -> dict[str, float]:
        """Env e's `episode_metrics()`, scored by the template env's own code (`columns`: its
        trace from `TraceRing.columns_of`, when read already)."""
        if self.ring is None:
            raise RuntimeError("episode metrics were switched off (record_metrics=False)")
        tpl = self.template
        constant = {c: 0.0 for c in ("yaw_rad", "accelerator", "brake")} | {"headway_s": math.inf, "ttc_s": math.inf, "gap_m": math.inf}
        constant["lead_speed_mps"] = math.nan
        constant = {k: v for k, v in constant.items() if k not in self.trace_columns}
        tpl.trace = self.ring.to_trace(e, self.guide, self.dt, constant, columns)
        w = tpl.world
        w.step_count = int(self.step_count[e])
        w.t_s = float(self.t[e])
        w.collisions = int(self.collisions[e])
        w.ego.powertrain.state.fuel_used_l = float(self.s.fuel_used[e])
        w.triggers.center.results = self.timers.results_of(e)
        self._load_episode(e, columns)
        return tpl.episode_metrics()
