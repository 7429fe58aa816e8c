"""The Lane Change Test for a native batch (`envs.lct.LaneChangeTestEnv`'s hooks over N envs).

Why: signs are revealed by their trigger boxes (`manipulateObject visible`), so each env
keeps the highest sign index revealed; the normative-path deviation, the reward and the
running MDEV accumulate per physics step, with the single env's formulas. A policy step is
one compiled parallel pass (`lct_step`): the action check, and chunk by chunk the autoresets,
the controls, the physics steps and every env's reward, flags, observation and info, so a
step's Python does the same small work whatever the batch size, apart from the rare trigger
firings that log a reaction result and the reaction timers that end (their chunks are
finished after Python handled them, `_step_rest`).
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from ..envs.base import LANE_KEEPING_OFFSET_M
from ..envs.lct import LaneChangeTestEnv
from ..envs.observations import EGO_NAMES, VEHICLE_NAMES
from ..metrics import episode_scores
from ..sim.controls import STEERING_WHEEL_MAX_DEG
from ..sim.triggers.core import CompiledAction
from .actions import BatchControls, action_block, first_nonfinite
from .core import BatchCore
from .episode_rows import table_of_rows
from .episode_table import EpisodeTable
from .kernels import CHUNK_ENVS
from .lanes_known import known_from, lanes_known_rows
from .lct_fire import fire_tables
from .lct_score_pass import lct_score_episodes, row_columns, score_episodes, score_worker, table_layout, wide_keys
from .lct_step import (
    INFO_F,
    INFO_I,
    _finish_range,
    _observation_range,
    _outcomes_range,
    _substeps_range,
    finish_chunks,
    lct_finish,
    lct_observation,
    lct_outcomes,
    lct_step,
    lct_step_serial,
    lct_substeps,
)
from .platoon import _BASE_KEYS
from .trace import TraceRing

# the info keys of a step, in `BatchCore.info`'s order
INFO_KEYS = ("sim_time_s", "speed_kmh", "lateral_offset_m", "lane_index", "fuel_used_l", "collisions", "reaction_result", "reaction_time_s",
             "mean_deviation_m", "sdlp_m", "headway_s", "ttc_s", "lanes_known", "resets", "reset_time_s", "progress_m",
             "new_collisions")  # fmt: skip
StepArrays = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray], list[int]]


def _chunks(n: int) -> int:
    """`kernels.chunk_count` in Python."""
    return max(1, (n + CHUNK_ENVS - 1) // CHUNK_ENVS)


class LctBatch(BatchCore):
    handled_actions = frozenset({"setupLaneChangeReactionTimer", "manipulateObject"})
    parallel_kernels = True  # its step kernels use numba's threads (`parallel`)
    checks_actions = True  # `step_and_reset` refuses NaN and infinity before any env moves (`NativeVectorEnv.step` relies on it)

    def __init__(self, template: LaneChangeTestEnv, n: int, record_metrics: bool = True) -> None:
        super().__init__(template, n, record_metrics)
        env = template
        cfg: Any = env.config
        self.norm = np.asarray(env._norm, dtype=np.float64)
        self.norm_d0, self.norm_step = env._norm_d0, env._norm_step
        self.sign_of_model = {}
        for k, spec in enumerate(env.sign_specs):
            for side in ("Left", "Right"):
                self.sign_of_model[f"LCT_Sign{spec.index:02d}_{side}"] = k
        self.sign_z = np.array([s.z_m for s in env.sign_specs] + [0.0])
        self.sign_lane = np.array([s.to_lane for s in env.sign_specs] + [env.initial_lane], dtype=np.int64)
        self.lane_lat = np.asarray(env.lane_laterals, dtype=np.float64)
        self.scale = cfg.reward_deviation_scale_m
        self.reward_scale = cfg.reward_scale
        self.off_road_penalty = cfg.off_road_penalty
        self.off_road_limit = env.half_road + cfg.off_road_margin_m
        self.revealed = np.full(n, -1, dtype=np.int64)  # highest sign index revealed (the visible one shown)
        self.area = np.zeros(n)
        self.step_reward = np.zeros(n)
        self.has_prev = np.zeros(n, dtype=bool)
        self.prev_d = np.zeros(n)
        self.prev_dev = np.zeros(n)
        if self.trace_columns != ("x_m", "z_m", "speed_mps", "steering") or self.has_traffic or self.needs_distance:
            raise TypeError("lct_step writes the LCT's trace columns and measures; change it with them")
        if self.ring is not None:  # grouped: each car's physics steps write its rows in turn; ended episodes read them in runs
            self.ring = TraceRing(n, self.trace_columns, self.ring.size - 2, grouped=True)
        self._no_block = np.empty((1, 1, 1, len(self.trace_columns)))
        self._no_steps = np.zeros(n, dtype=np.int64)
        self._steering = (np.zeros(n), np.zeros(n), np.zeros(n))  # lct_substeps' scratch
        # the step's kernels run chunks of envs on numba's threads (False: their serial twins, for Python threads and for
        # a batch of one chunk, which a parallel launch would only delay: waking the pool costs more than stepping it)
        self.parallel = n > CHUNK_ENVS
        self._live, self._rows = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)  # `lct_step`'s scratch: envs stepping (live: still)
        self._controls = (np.zeros(n), np.zeros(n), np.zeros(n))  # steering, gas, brake
        self._chunk_done = np.zeros(_chunks(n), dtype=bool)  # chunks whose outputs `lct_step` wrote
        self._score_worker = (0, -1)  # `SealedWorker.at`'s (address, tag) of `lct_score_episodes`' worker: none yet
        self._lists, self._counts = np.zeros((2, n), dtype=np.int64), np.zeros(3, dtype=np.int64)  # envs reset, envs that ended
        # (numba's threads at most: `lct_step`'s workers; with fewer threads set, a thread runs several, the first takes all chunks)
        config: Any = numba.config
        self._workers = int(config.NUMBA_NUM_THREADS)
        self._no_first = np.zeros(0)
        self._park = np.full(n, -1, dtype=np.int64)  # the physics step where a car waits for its triggers to fire (-1: none)
        self._score_params = episode_scores.scoring_params(cfg.physics_hz, self.off_road_limit, self.guide.road_edges_m)
        signs = env.metric_signs
        self._signs = (np.array([s.d_m for s in signs]), np.array([s.from_lane for s in signs], dtype=np.int64),
                       np.array([s.to_lane for s in signs], dtype=np.int64))  # fmt: skip
        self._iso = cfg.scoring == "iso26022"  # (ISO 26022's segment scores: the template's code)
        self._fire_tables = fire_tables(self.trig, self.timers, self.sign_of_model)
        self._wide_keys = wide_keys(_BASE_KEYS, len(signs))
        if record_metrics and not self._iso:  # the scoring kernel's compile (or cache load) done now, not at the first ends
            self._score_pass(np.zeros(0, dtype=np.int64))

    def _reset_task(self, idx: np.ndarray) -> None:
        self.revealed[idx] = -1
        self.area[idx] = 0.0
        self.step_reward[idx] = 0.0
        self.has_prev[idx] = False

    def step_rows(self, actions: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """`BatchCore.step_rows` with its ending (progress, info, reward, flags) in one compiled
        pass (`lct_outcomes`)."""
        c = self.actions.convert(actions, rows)
        self._physics_steps(rows.copy(), c)
        n, s, tm = self.n, self.s, self.timers
        floats = tuple(np.empty(n) for _ in range(6))
        new_collisions = np.empty(n, dtype=np.int64)
        reward, terminated, truncated = np.empty(n), np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        args = (rows, self.guide.sign, self.guide.start_xz[1], s.z, s.u, self.last_s, self.progress, self.collisions,
                     self.collisions_seen, self.new_collisions, tm.n_results, self.reaction_cursor, tm.last_result, tm.last_rt,
                     self.rl["n"], self.rl["m2"], self.has_prev, self.prev_d, self.area, self.lat, self.off_road_limit, self.step_reward,
                     self.reward_scale, self.off_road_penalty, self.trig.paused, bool(self.config.terminate_on_collision), self.t,
                float(self.config.max_episode_s), floats, (new_collisions,), reward, terminated, truncated)  # fmt: skip
        if self.parallel:
            lct_outcomes(*args)
        else:
            _outcomes_range(0, n, *args)
        speed_kmh, result, rt, mdev, sdlp, progress = floats
        info = {
            "sim_time_s": self.t.copy(),
            "speed_kmh": speed_kmh,
            "lateral_offset_m": self.offset.copy(),
            "lane_index": self.lane.copy(),
            "fuel_used_l": s.fuel_used.copy(),
            "collisions": self.collisions.copy(),
            "reaction_result": result,
            "reaction_time_s": rt,
            "mean_deviation_m": mdev,
            "sdlp_m": sdlp,
            "headway_s": self.headway.copy(),
            "ttc_s": self.ttc.copy(),
            "lanes_known": lanes_known_rows(self.guide, self.last_s),
            "resets": np.zeros(n, dtype=np.int64),  # (on_road_exit="terminate" only: never reset)
            "reset_time_s": np.zeros(n),
            "progress_m": progress,
            "new_collisions": new_collisions,
        }
        return reward, terminated, truncated, info

    def step_and_reset(self, actions: np.ndarray, resetting: np.ndarray, size: int) -> StepArrays:
        """`shards.step_shard`'s step with NEXT_STEP autoreset: the envs not `resetting` step,
        the others reset, then every env's reward, flags, observation and info are written (a
        reset env's are those of its fresh state, as `BatchCore.info` gives them after
        `reset_rows`). One compiled parallel pass (`lct_step`) checks the actions, resets,
        steps and writes the outputs chunk by chunk; Python only fires the rare triggers that
        log a reaction result and scores ended timers, then finishes their chunks. The info
        arrays are rows of two blocks allocated per step (the caller may keep them). Returns
        (obs, reward, terminated, truncated, info, envs whose episode ended)."""
        if size != len(EGO_NAMES) + self.template.config.nearby_vehicles * len(VEHICLE_NAMES) + 3:
            raise ValueError(f"the LCT observation has 7 ego features, vehicle slots and 3 stimulus values, not {size} values")
        a = action_block(actions, self.n, self.actions.width)
        if self.repeat > TraceRing.BLOCK:  # (a policy step longer than a ring block: a block at a time)
            return self._step_blocks(a, resetting, size)
        ring = self.ring
        outputs = self._outputs(size)
        if ring is not None:
            block_a, block_b = ring.reserve(self.repeat)
            row0, g0 = ring.g % ring.BLOCK, ring.g
        else:
            block_a = block_b = self._no_block
            row0 = g0 = 0
        sub = self._substeps_args(False, 0, self.repeat, self._live, block_a, block_b, row0, self._controls)[2:]
        fin = self._finish_args(self._rows, outputs)
        if len(fin[0]) != 31:
            raise TypeError("lct_step._list_ended reads terminated and truncated at 29 and 30 of the outcome tuple")
        chunks = self._chunk_done
        lists, counts = self._lists, self._counts
        prep = self._prep_args(g0 + self.repeat)
        call = lct_step if self.parallel else lct_step_serial  # (threads take chunks one at a time: `kernels.take_next`)
        bad, parked, ran = call(self._workers, a, resetting, self._rows, chunks, lists, counts, prep, sub, fin)
        if bad >= 0:
            raise ValueError(f"env {bad}: action contains NaN or infinity: {np.asarray(a[bad], dtype=np.float64).tolist()}")
        resets = int(counts[1])
        if resets:  # (`TimerBatch.reset_rows`' Python lists; nothing in `lct_step` reads them)
            self.timers.clear_results(lists[0, :resets])
        if not chunks.all() if self.parallel else not chunks[0]:
            ran = self._step_rest(parked, ran, block_a, block_b, row0, outputs)
        if ring is not None:
            ring.g = g0 + ran
            if resets and ran != self.repeat:  # (every car stopped early: `TraceRing.reset_rows`' start is the next write)
                ring.start[resetting] = ring.g
        return self._returns(outputs, sorted(lists[1, : counts[2]].tolist()))

    def _step_rest(self, parked: int, ran: int, block_a: np.ndarray, block_b: np.ndarray, row0: int, outputs: tuple) -> int:
        """`step_and_reset` after `lct_step`, for the chunks whose cars wait for Python: score
        the timers that ended, fire the parked cars' triggers and step them on
        (`lct_substeps`, resuming, as `_substeps`), then write those chunks' outputs. Returns
        the most physics steps run."""
        trig, timers = self.trig, self.timers
        while True:
            if timers.done.any():
                timers.score_ended(trig.started_at)
            if not parked:
                break
            env = np.flatnonzero(trig.contact >= 0)
            trig.fire(self.t, env, trig.contact[env], self._run_action)
            args = self._substeps_args(True, 0, self.repeat, self._live, block_a, block_b, row0, self._controls)
            parked, resumed = lct_substeps(*args) if self.parallel else _substeps_range(0, self.n, *args)
            ran = max(ran, resumed)
        done = self._chunk_done if self.parallel else self._chunk_done[:1]
        finish_chunks(done, self.n, self._lists, self._counts, *self._finish_args(self._rows, outputs))
        return ran

    def _step_blocks(self, a: np.ndarray, resetting: np.ndarray, size: int) -> StepArrays:
        """`step_and_reset` as separate passes: the physics steps a ring block at a time
        (`_substeps`), the resets (`reset_rows`), then the outputs (`_finish`)."""
        stepping = ~resetting
        bad = first_nonfinite(a, stepping)
        if bad >= 0:
            raise ValueError(f"env {bad}: action contains NaN or infinity: {np.asarray(a[bad], dtype=np.float64).tolist()}")
        c = self.actions.convert(np.asarray(a, dtype=np.float64), stepping, checked=True)
        with numba.parallel_chunksize(1):
            self._substeps(stepping.copy(), c)
            if resetting.any():
                self.reset_rows(np.flatnonzero(resetting), None)
            return self._finish(stepping, size)

    def _outputs(self, size: int) -> tuple[np.ndarray, ...]:
        """A step's output arrays: (obs, reward, terminated, truncated, info floats, info ints, lanes known)."""
        n = self.n
        return (np.empty((n, size), dtype=np.float32), np.empty(n), np.empty(n, dtype=bool), np.empty(n, dtype=bool),
                np.empty((len(INFO_F), n)), np.empty((len(INFO_I), n), dtype=np.int64), np.empty(n, dtype=bool))  # fmt: skip

    def _returns(self, outputs: tuple[np.ndarray, ...], ended: list[int] | None = None) -> StepArrays:
        """`step_and_reset`'s returns from the output arrays (`ended`: the envs whose episode ended, when listed already)."""
        out, reward, terminated, truncated, info_f, info_i, known = outputs
        info = dict(zip(INFO_F, info_f)) | dict(zip(INFO_I, info_i))
        info["lanes_known"] = known
        info = {key: info[key] for key in INFO_KEYS}
        return out, reward, terminated, truncated, info, np.flatnonzero(terminated | truncated).tolist() if ended is None else ended

    def _prep_args(self, g_end: int) -> tuple:
        """`lct_step`'s `prep`: `lct_step._prepare_range`'s arguments after `rows` (`g_end`: the
        trace ring's row count after a whole policy step)."""
        s, p, trig, tm, rl, g = self.s, self.p, self.trig, self.timers, self.rl, self.guide
        ring = self.ring
        first = tuple(ring.first[c] for c in self.trace_columns) if ring is not None else (self._no_first,) * 4
        return (self._live, self._controls, self.actions.held, p.reset_pose,
                (p.initial_speed, p.initial_gear, p.initial_rpm, p.initial_fuel),
                (s.x, s.y, s.z, s.yaw, s.u, s.v, s.r, s.rpm, s.prev_v, s.fuel_used, s.fuel_left, s.steer_in, s.gas_in, s.brake_in,
                 s.cruise_target, s.cruise_int), s.gear, s.cruise_on,
                (trig.locks, trig.counts, trig.paused, trig.started, trig.started_at), (tm.active, tm.kind, tm.n_results),
                (self.step_count, self.collisions, self.collisions_seen, self.reaction_cursor, self.new_collisions),
                (self.t, self.progress, rl["n"], rl["mean"], rl["m2"], rl["area"], rl["dist"], self.area, self.step_reward),
                (self.revealed, self.has_prev, self.last_s), (g.sign, g.start_xz[1]),
                (self.centres, g.lane_width_m / 2.0, LANE_KEEPING_OFFSET_M, self.lat, self.lane, self.offset), ring is not None, first,
                ring.steps if ring is not None else self._no_steps, (ring.start if ring is not None else self._no_steps, g_end),
                self.draws)  # fmt: skip

    def _finish_args(self, stepping: np.ndarray, outputs: tuple[np.ndarray, ...]) -> tuple:
        """`lct_finish`'s arguments for the envs `stepping` (the others were reset) and the output arrays."""
        s, tm = self.s, self.timers
        out, reward, terminated, truncated, info_f, info_i, known = outputs
        outcome = (stepping, self.guide.sign, self.guide.start_xz[1], s.z, s.u, self.last_s, self.progress, self.collisions,
                   self.collisions_seen, self.new_collisions, tm.n_results, self.reaction_cursor, tm.last_result, tm.last_rt,
                   self.rl["n"], self.rl["m2"], self.has_prev, self.prev_d, self.area, self.lat, self.off_road_limit, self.step_reward,
                   self.reward_scale, self.off_road_penalty, self.trig.paused, bool(self.config.terminate_on_collision), self.t,
                   float(self.config.max_episode_s), reward, terminated, truncated)  # fmt: skip
        obs = (out, s.u, s.yaw, self.guide.road_heading, self.offset, self.lat, self.lane, s.steer_in, s.r, s.z, self.revealed,
               self.sign_z, self.sign_lane, self.lane_lat)  # fmt: skip
        copies = (self.t, self.offset, s.fuel_used, self.headway, self.ttc, self.lane, self.collisions)
        return outcome, obs, copies, info_f, info_i, known, known_from(self.guide)

    def _finish(self, stepping: np.ndarray, size: int) -> StepArrays:
        """`step_and_reset`'s outputs (`lct_finish`)."""
        outputs = self._outputs(size)
        args = self._finish_args(stepping, outputs)
        if self.parallel:
            lct_finish(*args)
        else:
            _finish_range(0, self.n, *args)
        return self._returns(outputs)

    def observation(self, k: int, size: int) -> np.ndarray:
        """The ego features, empty vehicle slots and the sign stimulus (`lct_observation`)."""
        if size != len(EGO_NAMES) + k * len(VEHICLE_NAMES) + 3:
            raise ValueError(f"the LCT observation has 7 ego features, {k} empty vehicle slots and 3 stimulus values, not {size} values")
        out = np.empty((self.n, size), dtype=np.float32)
        s = self.s
        args = (out, s.u, s.yaw, self.guide.road_heading, self.offset, self.lat, self.lane, s.steer_in, s.r, s.z, self.revealed,
                self.sign_z, self.sign_lane, self.lane_lat)  # fmt: skip
        if self.parallel:
            lct_observation(*args)
        else:
            _observation_range(0, self.n, *args)
        return out

    def _physics_steps(self, live: np.ndarray, c: BatchControls) -> None:
        """`BatchCore._physics_steps` as one compiled loop (`lct_step`, trigger actions
        included), back in Python to score ended timers and to fire the few triggers that log
        a reaction result (`lct_fire`). A
        policy step of more physics steps than a ring block holds runs a block at a time."""
        with numba.parallel_chunksize(1):  # threads take the chunks one at a time: a busy core holds up one chunk, not half
            self._substeps(live, c)

    def _substeps(self, live: np.ndarray, c: BatchControls) -> None:
        trig, timers, ring = self.trig, self.timers, self.ring
        k_from = 0
        while k_from < self.repeat:
            k_to = min(self.repeat, k_from + TraceRing.BLOCK)
            block_a, block_b = ring.reserve(k_to - k_from) if ring is not None else (self._no_block, self._no_block)
            row0 = ring.g % ring.BLOCK - k_from if ring is not None else 0
            steps, resume = k_from, False
            while True:
                args = self._substeps_args(resume, k_from, k_to, live, block_a, block_b, row0, (c.steer, c.gas, c.brake))
                parked, ran = lct_substeps(*args) if self.parallel else _substeps_range(0, self.n, *args)
                steps = max(steps, ran)
                if timers.done.any():  # (before firing: a timer a trigger re-arms is scored first)
                    timers.score_ended(trig.started_at)
                if not parked:
                    break
                env = np.flatnonzero(trig.contact >= 0)
                trig.fire(self.t, env, trig.contact[env], self._run_action)
                resume = True
            if ring is not None:
                ring.g += steps - k_from
            if steps < k_to:  # every car stopped early
                break
            k_from = k_to

    def _substeps_args(self, resume: bool, k_from: int, k_to: int, live: np.ndarray, block_a: np.ndarray, block_b: np.ndarray, row0: int,
                       controls: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple:  # fmt: skip
        """`lct_substeps`' arguments after `resume`, k_from and k_to (the envs `live` step; trace rows from `row0` of the blocks)."""
        s, trig, timers, ring, g = self.s, self.trig, self.timers, self.ring, self.guide
        ego_f = (s.x, s.z, s.yaw, s.u, s.v, s.r, s.rpm, s.prev_v, s.fuel_used, s.fuel_left, s.steer_in, s.gas_in, s.brake_in,
                 s.cruise_target, s.cruise_int)  # fmt: skip
        timer_f = (timers.start_t, timers.start_x, timers.start_z, timers.peak, timers.hold_since, timers.tlim, timers.dlim)
        fire = (*self._fire_tables, trig.counts, trig.started, trig.started_at, self.revealed, timers.kind, timers.armed_t)
        steer, gas, brake = controls
        return (
            resume, k_from, k_to, self.dt, live, self._park, self.step_count, self.t, trig.paused, self.p.car, self.p.engine_on,
            self.p.suppress_cruise_off, self.p.min_speed, ego_f, s.gear, s.cruise_on, steer, gas, brake, self.car_shift,
            self.car_half[0], self.car_half[1], trig.vols, trig.vol_triggers, trig.locks, trig.near, trig.contact,
            bool(timers.specs), timers.active, timers.spec, timer_f, timers.braked, timers.start_lane,
            timers.table, timers.band_table, timers.done, timers.done_t, g.sign, self.centres, g.lane_width_m / 2.0,
            LANE_KEEPING_OFFSET_M, self.lat, self.lane, self.offset, (self.rl["n"], self.rl["mean"], self.rl["m2"]),
            ring is not None, block_a, block_b, row0, ring.steps if ring is not None else self._no_steps, self.start_z,
            self.norm, self.norm_d0, self.norm_step, self.scale, self.has_prev,
            (self.prev_d, self.prev_dev, self.area, self.step_reward), self.off_road_limit, self._steering, fire,
        )  # fmt: skip

    def episodes_metrics(self, es: list[int]) -> list[tuple[int, dict[str, float]]]:
        """`episode_metrics` of the envs `es`, the same floats: `episodes_table`'s rows as dicts,
        each with its keys in the single env's order."""
        if self.ring is None:
            raise RuntimeError("episode metrics were switched off (record_metrics=False)")
        if self._iso or not es:
            columns = self.ring.columns_of(es)
            return [(e, self.episode_metrics(e, columns[e])) for e in es]
        return list(zip(es, self._row_dicts(*self._scored(es)), strict=True))

    def _row_dicts(self, wide: np.ndarray, passed: np.ndarray, slow: dict[int, dict[str, float]]) -> list[dict[str, float]]:
        """`_scored`'s rows as dicts, each with its keys in the single env's order."""
        signs, keys = len(self._signs[0]), self._wide_keys
        out = []
        for j, (row, p) in enumerate(zip(wide.tolist(), passed.tolist(), strict=True)):
            at = row_columns(signs, p) if p >= 0 else ()
            out.append(slow[j] if p < 0 else {keys[c]: math.nan if row[c] != row[c] else row[c] for c in at})
        return out

    def episodes_table(self, es: list[int]) -> EpisodeTable:
        """`episode_metrics` of the envs `es` as one table (rows equal `episodes_metrics`' dicts),
        scored in one parallel compiled pass (`lct_score_pass`): the generic trace metrics
        (`metrics.episode_scores`), the LCT's scoring of instructed lane changes
        (`metrics.lct_scores.lct_scores`) and, for the episodes that passed a sign, the
        lane-change fits and MDEV (`lct_lane_changes`). Episodes scored by ISO 26022
        (`scoring="iso26022"`) are scored by the template env's own code."""
        if self.ring is None:
            raise RuntimeError("episode metrics were switched off (record_metrics=False)")
        if self._iso or not es:
            return table_of_rows([m for _, m in self.episodes_metrics(es)])
        wide, passed, slow = self._scored(es)
        if slow:  # (rare: the template's dicts next to the compiled rows, scored once)
            return table_of_rows(self._row_dicts(wide, passed, slow))
        return self._wide_table(wide, passed)

    def _scored(self, es: list[int]) -> tuple[np.ndarray, np.ndarray, dict[int, dict[str, float]]]:
        """(`lct_score_pass`' wide rows, signs passed, the template's metrics of the episodes
        the pass left to it (passed -1: one row past a sign), by row)."""
        assert self.ring is not None
        wide, passed = self._score_pass(np.asarray(es, dtype=np.int64))
        slow = {j: self.episode_metrics(es[j]) for j in np.flatnonzero(passed < 0).tolist()}
        return wide, passed, slow

    def _wide_table(self, wide: np.ndarray, passed: np.ndarray) -> EpisodeTable:
        """The table of `lct_score_pass`' wide rows: each row's keys (by its signs passed), in
        order of first appearance."""
        order = tuple(dict.fromkeys(passed.tolist()))  # (the distinct counts in order of first appearance)
        keys, columns, present = table_layout(self._wide_keys, len(self._signs[0]), order)
        values = wide[:, columns]
        if present is None:
            return EpisodeTable(keys, values, None)
        mask = present[passed]
        values[~mask] = 0.0  # (absent keys: 0, as `episode_rows.table_of_rows` leaves them)
        return EpisodeTable(keys, values, mask)

    def _score_pass(self, es: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`lct_score_pass.score_episodes` of the episodes of the envs `es` so far, read from
        the ring: (wide rows, signs passed)."""
        g, tpl, tm, ring = self.guide, self.template, self.timers, self.ring
        assert ring is not None
        if g.kind != "lanes":
            raise ValueError("the native batch needs a task with lane bands")
        geo = tpl.geometry
        trace_p = (self.dt, g.sign, self.centres, g.lane_width_m / 2.0, STEERING_WHEEL_MAX_DEG)
        lct_p = (self.start_z, *self._signs, geo.visibility_m, tpl.basic.start_before_sign_m, tpl.basic.length_per_lane_m, self.lane_lat,
                 int(tpl.initial_lane), geo.speed_kmh / 3.6)  # fmt: skip
        consts = np.array([float(g.lanes_known), float(tpl.resets), float(tpl.collision_resets), float(tpl.reset_time_s)])
        env_p = (self.t, self.s.fuel_used, self.collisions, consts)
        react = (tm.n_results, tm.result_code, tm.result_rt, tm.result_spec, tm.sign_of_spec)
        m = len(es)
        wide, passed = np.empty((m, len(self._wide_keys))), np.empty(m, dtype=np.int64)
        blocks, b0 = ring.block_addresses()
        first = tuple(ring.first[c] for c in ring.columns)
        args = (es, blocks, b0, first, ring.start, ring.steps, trace_p, self._score_params, lct_p, env_p, react, wide, passed)
        if self.parallel:
            with numba.parallel_chunksize(1):  # (episodes differ in length: threads take one at a time)
                if not lct_score_episodes(*self._score_worker, *args):  # type: ignore[arg-type]  # (the first call, or other types)
                    self._score_worker = score_worker.at(args)
                    lct_score_episodes(*self._score_worker, *args)  # type: ignore[arg-type]
        else:
            score_episodes(0, m, *args)
        return wide, passed

    def _on_action_rows(self, es: np.ndarray, act: CompiledAction, trigger: int) -> None:
        if act.name == "manipulateObject":
            k = self.sign_of_model.get(str(act.args["object_id"]))
            if k is not None and act.args.get("visible"):
                self.revealed[es] = np.maximum(self.revealed[es], k)
            return
        super()._on_action_rows(es, act, trigger)

    def _task_info(self, info: dict[str, np.ndarray]) -> None:
        dist = np.where(self.has_prev, self.prev_d, 0.0)
        info["mean_deviation_m"] = np.where(dist > 0, self.area / np.where(dist > 0, dist, 1.0), 0.0)
