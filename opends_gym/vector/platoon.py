"""The platoon and brake-reaction tests for a native batch (`envs.platoon_core` over N envs).

Why: the lead/follower band control, the stimuli (`setTVPTStimulus`) and their reaction
rules run every physics step, so they run in the compiled pass of the policy step
(`platoon_pass.platoon_substeps`: ego car, traffic, triggers, timers, then
`platoon_step.after_one`): each env has a few stimulus slots (onset, end, target, result,
hold time); starting a stimulus (a trigger's action) and recording a result are rare and
keep the single env's `Stimulus` records per env. Ended episodes are scored in two
compiled passes over all of them (`metrics.episode_scores`, `metrics.platoon_scores`),
with the single env's floats.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from ..envs.base import LANE_KEEPING_OFFSET_M, OpenDSEnv
from ..envs.brake import brake_metrics
from ..envs.observations import EGO_NAMES, VEHICLE_NAMES
from ..envs.platoon import ThreeVehiclePlatoonEnv
from ..envs.platoon_core import (
    BAND_GAIN,
    BRAKE_THRESHOLD,
    FOLLOWER_CATCH_UP_MPS,
    FOLLOWER_GAIN_PER_S,
    REGULAR_SPEED_TOLERANCE_MPS,
    PlatoonState,
    Stimulus,
)
from ..metrics import episode_scores
from ..metrics import platoon_scores as scores
from ..sim.controls import STEERING_WHEEL_MAX_DEG
from ..sim.traffic.routes import TURN_CODES
from ..sim.traffic.state import N_COLUMNS
from ..sim.triggers.core import CompiledAction
from .actions import SIGNAL_OFF, BatchControls
from .core import BatchCore
from .episode_table import EpisodeTable
from .kernels import CHUNK_ENVS
from .platoon_controls import PARALLEL_CONTROLS_ENVS, step_controls, step_controls_parallel
from .platoon_finish import INFO_F, INFO_I, _finish_range, platoon_finish
from .platoon_pass import TRAFFIC, _substeps_range, platoon_substeps, traffic_events
from .platoon_reset import reset_envs, reset_range
from .platoon_score_pass import score_episodes, score_range
from .platoon_step import _lead_range, lead_measures, lead_rows
from .trace import PLATOON_TRACE_GROUP, TraceRing, episode_chunks
from .traffic import FlatTraffic

KINDS = scores.KINDS
_BASE_KEYS = (
    "duration_s",
    *episode_scores.KEYS[:2],
    "fuel_used_l",
    "collisions",
    *episode_scores.KEYS[2:6],
    "reactions",
    "reactions_correct",
    "reactions_failed",
    "reactions_missed",
    "mean_reaction_time_s",
    "lanes_known",
    *episode_scores.KEYS[6:8],
    "stimuli_presented",
    "road_exits",
    "resets",
    "collision_resets",
    "reset_time_s",
    *episode_scores.KEYS[9:],
)  # (`OpenDSEnv.episode_metrics`' keys in its order, before the task's own)
# the info keys of a step, in `BatchCore.info`'s order
INFO_KEYS = ("sim_time_s", "speed_kmh", "lateral_offset_m", "lane_index", "fuel_used_l", "collisions", "reaction_result", "reaction_time_s",
             "mean_deviation_m", "sdlp_m", "headway_s", "ttc_s", "lanes_known", "resets", "reset_time_s", "progress_m",
             "new_collisions")  # fmt: skip
StepArrays = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray], list[int]]
BL, LT, FT, SR, EB = range(5)
SLOTS = 4  # simultaneous stimuli per env (a stimulus lasts <= 5 s; triggers lie >= 250 m apart)


def _rows_with_nan(a: np.ndarray) -> list[list[float]]:
    """`a.tolist()` with each NaN as `math.nan` (as the single env's metrics hold them): the
    floats made once (an object array), the NaNs replaced by numpy (a platoon episode has
    a dozen or more; a Python loop over them cost more than the rest of its scoring)."""
    values = a.astype(object)
    values[np.isnan(a)] = math.nan
    rows: list[list[float]] = values.tolist()
    return rows


class PlatoonBatch(BatchCore):
    handled_actions = frozenset({"setTVPTStimulus"})
    trace_columns: tuple[str, ...] = ("x_m", "z_m", "speed_mps", "steering", "headway_s", "ttc_s", "gap_m", "lead_speed_mps", "lon_dev")
    needs_distance = True
    has_traffic = True
    parallel_kernels = True  # its step pass runs chunks of envs on numba's threads (`parallel`)
    checks_actions = True  # `step_and_reset` refuses NaN and infinity before any env moves (`NativeVectorEnv.step` relies on it)
    has_extra_metrics = False  # the task adds its own metrics (`_extra_table`, keys `extra_keys`)
    extra_keys: tuple[str, ...] = ()

    def __init__(self, template: ThreeVehiclePlatoonEnv, n: int, record_metrics: bool = True) -> None:
        template.reset(seed=0)  # the cars as the task's reset leaves them (the same for every seed)
        super().__init__(template, n, record_metrics)
        core = template.platoon
        tm = self.world.traffic
        self.spec = core.spec
        self.with_follower = core.with_follower
        self.nominal = core.nominal_mps
        self.lead_i, self.follow_i = tm.index_of(core.lead), tm.index_of(core.follower)
        spec = self.world.ego.spec
        self.traffic = FlatTraffic(tm, n, spec.length_m, self.car_half, car_major=True)  # (the pass steps a world at a time)
        self.em_decel = self.world.task.scenario.vehicles[self.lead_i].deceleration_brake_mps2
        sr = self.spec.speed_reduction
        self.durations = np.array(
            [self.spec.brake_light_min_duration_s or 2.5, self.spec.turn_signal_duration_s or 2.5, self.spec.turn_signal_duration_s or 2.5]
            + [sr.duration_s if sr else 0.0] * 2
        )
        self.reset_on = np.array(
            [self.spec.brake_light_reset_on_reaction, self.spec.turn_signal_reset_on_reaction, self.spec.turn_signal_reset_on_reaction]
            + [bool(sr and sr.reset_on_reaction)] * 2
        )
        shape = (n, SLOTS)
        self.on = np.zeros(shape, dtype=bool)
        self.kind = np.zeros(shape, dtype=np.int64)
        self.onset = np.zeros(shape)
        self.end = np.zeros(shape)
        self.target = np.zeros(shape)
        self.car = np.zeros(shape, dtype=np.int64)
        self.result = np.zeros(shape, dtype=np.int64)
        self.hold = np.full(shape, np.nan)
        self.objs: list[list[Stimulus | None]] = [[None] * SLOTS for _ in range(n)]
        self.stimuli: list[list[Stimulus]] = [[] for _ in range(n)]
        self.n_stimuli = np.zeros(n, dtype=np.int64)  # len(self.stimuli[e])
        self.n_brake_stimuli = np.zeros(n, dtype=np.int64)  # the brake light and emergency brake stimuli among them
        self.prng: list[np.random.Generator | None] = [None] * n  # built from `prng_seed` when first drawn from
        self.prng_seed = np.zeros(n, dtype=np.int64)
        self._prng_built = np.zeros(n, dtype=bool)  # prng[e] is not None
        self._seeded = np.zeros(n, dtype=bool)  # reset once (`reset_rows`: an autoreset of these is compiled)
        self._c = BatchControls(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64))  # `_controls`
        cfg: Any = template.config
        self.dev_cap, self.dev_per_m = cfg.reward_deviation_cap_m, cfg.reward_deviation_per_m
        self.progress_per_m, self.off_road_penalty = cfg.reward_progress_per_m, cfg.off_road_penalty
        self.collision_penalty = cfg.collision_penalty
        self.ttc_weight, self.ttc_threshold = cfg.reward_ttc_weight, cfg.reward_ttc_threshold_s
        self.end_past_lead = bool(cfg.end_when_past_lead)
        self.off_road_limit = len(self.world.road.lanes) * cfg.lane_width_m / 2 + cfg.off_road_margin_m
        self.reward_acc = np.zeros(n)
        self.seen = np.zeros(n, dtype=np.int64)
        self.dirty = np.zeros(n, dtype=bool)
        self.lon_dev = np.zeros(n)
        self.lead_j = np.full(n, -1, dtype=np.int64)
        self.lead_gap = np.zeros(n)
        self.lead_v = np.zeros(n)
        self.gap_m = np.full(n, np.inf)
        self.lead_speed_mps = np.full(n, np.nan)
        self._half_len = np.ascontiguousarray(self.traffic.half[:, 1])
        self._sin, self._cos = np.zeros(n), np.zeros(n)  # the kernels' scratch: sine and cosine of each yaw
        lb, fb = self.spec.leading_car, self.spec.follower_car
        band, lat_band = self.spec.longitudinal_tolerance, self.spec.lateral_tolerance
        assert band is not None and lat_band is not None, "the native batch needs both tolerance bands"
        self._band = tuple(
            float(v)
            for v in (self.nominal, BAND_GAIN, lb.min_distance_m, lb.max_distance_m, FOLLOWER_GAIN_PER_S, FOLLOWER_CATCH_UP_MPS,
                      fb.min_distance_m, fb.max_distance_m, band.lower_bound_m, band.upper_bound_m, lat_band.lower_bound_m,
                      lat_band.upper_bound_m, self.dev_cap, self.dev_per_m, self.ttc_weight, self.ttc_threshold, self.repeat, SR)
        )  # fmt: skip
        # chunks on numba's threads (False: the serial twins, for thread shards and batches of one chunk)
        self.parallel = n > CHUNK_ENVS
        self._changed = np.zeros(shape, dtype=np.int64)  # the pass's stimuli that changed result (1 missed, 2 reacted)
        self._react = np.zeros(shape)  # and their reaction times
        self._held = np.zeros(shape)  # and their hold clocks then
        self._park = np.full(n, -1, dtype=np.int64)  # the physics step where an env waits for Python (-1: none) ...
        self._stage = np.zeros(n, dtype=np.int64)  # ... to finish its traffic or fire its triggers (`platoon_pass`)
        tr = self.traffic
        self._ego3 = np.zeros((3, n))  # each world's ego car for its traffic: x, z, speed (no car here watches the ego's speed)
        self._brake_out, self._turn_out = np.zeros(n * tr.c, dtype=bool), np.zeros(n * tr.c, dtype=np.int64)  # (scratch)
        self._net, self._quiet = np.zeros((1, N_COLUMNS)), np.zeros(n * tr.c, dtype=bool)  # (no road network: every leg end is Python's)
        self._car_rows = np.ones(n * tr.c, dtype=bool)
        self._codes = np.zeros(n, dtype=np.int64)  # each world's traffic code (`motion.step_rows`)
        self._ego4 = np.zeros((4, n))  # `platoon_finish`'s scratch: each ego car's x, z, yaw, speed for the vehicle slots
        self._bonus, self._n_bonus = np.zeros((n, 2 * SLOTS)), np.zeros(n, dtype=np.int64)  # (`_bonuses`)
        self._no_signs, self._no_sign_z = np.zeros((n, 0), dtype=bool), np.zeros(0)
        sr_spec = self.spec.speed_reduction
        self._stim_consts = np.array([BRAKE_THRESHOLD, REGULAR_SPEED_TOLERANCE_MPS, sr_spec.min_time_all_conditions_met_s if sr_spec else
                                      math.inf, self.spec.max_reaction_time_s, SR])  # fmt: skip
        self._pedals = self.trace_columns[9:] == ("accelerator", "brake")
        if self.trace_columns[:9] != PlatoonBatch.trace_columns or len(self.trace_columns) not in (9, 11) or SIGNAL_OFF != 0:
            raise TypeError("platoon_step.after_one writes these trace columns; change it with them")
        if self.ring is not None:  # grouped: each env's physics steps write its rows in turn (`platoon_pass`); ended episodes read runs
            self.ring = TraceRing(n, self.trace_columns, self.ring.size - 2, grouped=True, group=PLATOON_TRACE_GROUP)
        self._no_block = np.empty((1, 1, PLATOON_TRACE_GROUP, len(self.trace_columns)))
        self._no_steps = np.zeros(n, dtype=np.int64)
        self._no_hits = np.zeros(n, dtype=np.int64)
        self._scored: dict[int, dict[str, float]] = {}  # `PlatoonCore.metrics` of envs to score by the template (`episode_metrics`)
        if type(template)._instructed_lane_keeping is not OpenDSEnv._instructed_lane_keeping or template.on_road_exit != "terminate":
            raise TypeError("episode_scores scores tasks without instructed lane changes or resets; change it with them")
        self._score_params = episode_scores.scoring_params(cfg.physics_hz, self.off_road_limit, self.guide.road_edges_m)

    # ------------------------------------------------------------------ reset
    def _world_seed(self, e: int) -> None:
        # `World.reset(seed=...)`'s draw (unused: the batch's worlds use no randomness), then the seed of the env's
        # stimulus generator (the single env seeds it at reset): both drawn when the env's generator is next read
        # (`_draw_world_seed`; `_prng` reads it), as a compiled reset leaves them (`platoon_reset`). Most episodes under
        # random actions end before their first stimulus, so neither the draws nor the generator are made for them.
        self.draws[e] += 1

    def _draw_world_seed(self, e: int, rng: np.random.Generator) -> None:
        rng.integers(0, 2**31 - 1)
        self.prng_seed[e] = rng.integers(0, 2**31 - 1)  # (a later reset's overwrites an earlier one's: the last is the episode's)

    def reset_rows(self, idx: np.ndarray, seeds: list[int | None] | None) -> None:
        """`BatchCore.reset_rows`; an autoreset (seeds None) of envs reset before is one compiled
        call (`platoon_reset.reset_envs`), Python only emptying the lists that hold something."""
        if seeds is None and self._seeded[idx].all():
            self._autoreset(idx)
            return
        super().reset_rows(idx, seeds)
        self._seeded[idx] = True

    def _autoreset(self, idx: np.ndarray) -> None:
        stimuli, objs, prng = self.stimuli, self.objs, self.prng
        for e in idx[self.n_stimuli[idx] > 0].tolist():  # (lists replaced only when used: fewer objects for Python's garbage collector)
            stimuli[e] = []
            objs[e] = [None] * SLOTS
        built = idx[self._prng_built[idx]]
        for e in built.tolist():
            prng[e] = None
        self._prng_built[built] = False
        self.timers.clear_results(idx[self.timers.n_results[idx] > 0])
        s, p, trig, tm, rl, g, tr = self.s, self.p, self.trig, self.timers, self.rl, self.guide, self.traffic
        st, st0 = tr.st, tr.st0
        args = (np.asarray(idx, dtype=np.int64), p.reset_pose, (p.initial_speed, p.initial_gear, p.initial_rpm, p.initial_fuel),
                (s.x, s.y, s.z, s.yaw, s.u, s.v, s.r, s.rpm, s.prev_v, s.fuel_used, s.fuel_left, s.steer_in, s.gas_in, s.brake_in,
                 s.cruise_target, s.cruise_int), s.gear, s.cruise_on,
                (trig.locks, trig.counts, trig.paused, trig.started, trig.started_at), (tm.active, tm.kind, tm.n_results),
                self.actions.held, (self.step_count, self.collisions, self.collisions_seen, self.reaction_cursor, self.new_collisions),
                (self.t, self.progress, rl["n"], rl["mean"], rl["m2"], rl["area"], rl["dist"], self.last_s), (g.sign, g.start_xz[1]),
                (self.centres, g.lane_width_m / 2.0, LANE_KEEPING_OFFSET_M, self.lat, self.lane, self.offset, self.prev_x, self.prev_z),
                (st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, st.stuck_hist, tr.c),
                (st0.f, st0.i, st0.b, st0.pos, st0.end_xz, st0.light_xz, st0.ext_cmd, st0.stuck_hist), tr.hitting,
                (self.on, self.n_stimuli, self.n_brake_stimuli, self.reward_acc, self.seen, self.dirty), self._signs()[0],
                (st.pos, st.yaw, st.speed, st.enabled, self._half_len, tr.c, tr.ego_length, self.lead_j, self.lead_gap, self.lead_v,
                 self.headway, self.ttc, self.gap_m, self.lead_speed_mps), self.draws)  # fmt: skip
        if self.parallel:  # (chunks of the envs reset on numba's threads)
            reset_envs(*args)
        else:
            reset_range(0, len(idx), *args)
        if self.ring is not None:
            self._write_trace(self._mask(idx), first=True)

    def _reset_task(self, idx: np.ndarray) -> None:
        stimuli, objs, prng = self.stimuli, self.objs, self.prng
        for e in idx.tolist():  # (lists replaced only when used: fewer objects for Python's garbage collector)
            prng[e] = None
            if stimuli[e]:
                stimuli[e] = []
                objs[e] = [None] * SLOTS
        self._prng_built[idx] = False
        self.traffic.reset_rows(idx, self.traffic.st0)
        self.on[idx] = False
        self.n_stimuli[idx] = 0
        self.n_brake_stimuli[idx] = 0
        self.reward_acc[idx] = 0.0
        self.seen[idx] = 0
        self.dirty[idx] = False

    # ------------------------------------------------------------------ world
    def _lead_measures(self) -> None:
        s, st = self.s, self.traffic.st
        args = (s.x, s.z, s.yaw, s.u, st.pos, st.yaw, st.speed, st.enabled, self._half_len, self.traffic.c, self.traffic.ego_length,
                self.lead_j, self.lead_gap, self.lead_v, self.headway, self.ttc)  # fmt: skip
        if self.parallel:
            lead_measures(*args)
        else:
            _lead_range(0, self.n, *args)
        fin = (self.lead_j >= 0) & np.isfinite(self.lead_gap)
        self.gap_m = np.where(fin, self.lead_gap, np.inf)  # (trace columns, read by name)
        self.lead_speed_mps = np.where(fin, self.lead_v, np.nan)

    def _lead_measures_of(self, rows: np.ndarray | None) -> None:
        if rows is None or rows.all():
            self._lead_measures()
            return
        s, st = self.s, self.traffic.st  # (a reset: the other envs' measures are those their last physics step left)
        lead_rows(np.flatnonzero(rows), s.x, s.z, s.yaw, s.u, st.pos, st.yaw, st.speed, st.enabled, self._half_len, self.traffic.c,
                  self.traffic.ego_length, self.lead_j, self.lead_gap, self.lead_v, self.headway, self.ttc, self.gap_m,
                  self.lead_speed_mps)  # fmt: skip

    def vehicle_slots(self, k: int) -> np.ndarray | None:
        s = self.s
        return self.traffic.slots(k, s.x, s.z, s.yaw, s.u)

    def _distance_to(self, car: int) -> np.ndarray:
        s, st = self.s, self.traffic.st
        rows = np.arange(self.n) * self.traffic.c + car
        return (st.pos[rows, 0] - s.x) * -np.sin(s.yaw) + (st.pos[rows, 2] - s.z) * -np.cos(s.yaw)

    # ------------------------------------------------------------------ stimuli
    def _on_action(self, e: int, act: CompiledAction, trigger: int) -> None:
        if act.name != "setTVPTStimulus":
            return super()._on_action(e, act, trigger)
        kind = str(act.args.get("stimulus_id", ""))
        if kind == "turnSignal":
            rng = self._prng(e)
            kind = "leadingCarTurnSignal" if rng.random() < 0.5 or not self.with_follower else "followerCarTurnSignal"
        self._start(e, kind)

    def _prng(self, e: int) -> np.random.Generator:
        """Env e's stimulus generator (`ThreeVehiclePlatoonEnv`'s, seeded at reset)."""
        rng = self.prng[e]
        if rng is None:
            self.rng(e)  # (the world seeds left to draw: the last sets `prng_seed`)
            rng = self.prng[e] = np.random.default_rng(int(self.prng_seed[e]))
            self._prng_built[e] = True
        return rng

    def _start(self, e: int, kind: str) -> None:
        if kind not in KINDS or (KINDS.index(kind) >= SR and self.spec.speed_reduction is None):
            return  # the single env logs a warning and ignores it
        k = KINDS.index(kind)
        free = np.flatnonzero(~self.on[e])
        if free.size == 0:
            raise RuntimeError(f"env {e}: more than {SLOTS} simultaneous stimuli; use vectorization_mode='sync' for this geometry")
        slot = int(free[0])
        t = float(self.t[e])
        car = self.follow_i if k == FT else self.lead_i
        row = e * self.traffic.c + car
        st = self.traffic.st
        target = 0.0
        sr = self.spec.speed_reduction
        if k == BL:
            st.ov_brake[row] = 1
        elif k in (LT, FT):
            st.ov_turn[row] = TURN_CODES["left"]
        else:
            assert sr is not None
            lo, hi = (
                (sr.target_speed_min_regular_mps, sr.target_speed_max_regular_mps)
                if k == SR
                else (sr.target_speed_min_emergency_mps, sr.target_speed_max_emergency_mps)
            )
            target = float(self._prng(e).uniform(lo, hi))
            st.ov_speed[row] = max(0.0, target)
            st.ov_decel[row] = abs(self.em_decel) if k == EB else np.nan
        obj = Stimulus(kind, t, t + float(self.durations[k]), target_mps=target, car=self.world.traffic.ids[car])
        self.stimuli[e].append(obj)
        self.n_stimuli[e] += 1
        self.n_brake_stimuli[e] += k in (BL, EB)
        self.objs[e][slot] = obj
        self.on[e, slot], self.kind[e, slot], self.car[e, slot] = True, k, car
        self.onset[e, slot], self.end[e, slot], self.target[e, slot] = obj.onset_s, obj.end_s, target
        self.result[e, slot], self.hold[e, slot] = 0, np.nan

    def _physics_steps(self, live: np.ndarray, c: BatchControls) -> None:
        """`BatchCore._physics_steps` as one compiled pass (`platoon_pass.platoon_substeps`),
        back in Python only for the envs whose traffic or triggers need it (parked there),
        to score ended timers and to copy stimulus results into their records. A policy step
        of more physics steps than a ring block holds runs a block at a time."""
        with numba.parallel_chunksize(1):  # threads take the chunks one at a time: a busy core holds up one chunk, not half
            self._substeps(live, c)

    def _substeps(self, live: np.ndarray, c: BatchControls) -> None:
        s, st, tr, trig, timers, ring, g, p = self.s, self.traffic.st, self.traffic, self.trig, self.timers, self.ring, self.guide, self.p
        rl = self.rl
        controls = (c.steer, c.gas, c.brake)
        ego = (p.car, p.engine_on, p.suppress_cruise_off, p.min_speed, s.x, s.z, s.yaw, s.u, s.v, s.r, s.gear, s.rpm, s.prev_v, s.fuel_used,
               s.fuel_left, s.steer_in, s.gas_in, s.brake_in, s.cruise_on, s.cruise_target, s.cruise_int)  # fmt: skip
        trig_t = (trig.paused, self.car_shift, self.car_half[0], self.car_half[1], trig.vols, trig.vol_triggers, trig.locks, trig.near,
                  trig.contact)  # fmt: skip
        timer_t = (bool(timers.specs), timers.active, timers.spec, timers.start_t, timers.start_x, timers.start_z, timers.tlim, timers.dlim,
                   timers.peak, timers.hold_since, timers.braked, timers.start_lane, timers.table, timers.band_table, timers.done,
                   timers.done_t)  # fmt: skip
        a = (s.x, s.z, s.yaw, s.u, s.steer_in, s.gas_in, s.brake_in, self.t, self._sin, self._cos)
        lead = (st.pos, st.yaw, st.speed, st.enabled, self._half_len, tr.c, tr.ego_length, self.lead_j, self.lead_gap, self.lead_v,
                self.headway, self.ttc, self.gap_m, self.lead_speed_mps, tr.work)  # fmt: skip
        lanes = (g.sign, self.centres, g.lane_width_m / 2.0, LANE_KEEPING_OFFSET_M, self.lat, self.lane, self.offset, rl["n"], rl["mean"],
                 rl["m2"], self.prev_x, self.prev_z, rl["dist"], rl["area"])  # fmt: skip
        hook = (st.ov_speed, st.ov_decel, self.on, self.kind, self.car, self.lead_i, self.follow_i, bool(self.with_follower), self.lon_dev,
                self.reward_acc)  # fmt: skip
        stim = (self.kind, self.onset, self.end, self.target, self.result, self.hold, self.reset_on, c.pressed, c.signal, st.ov_brake,
                st.ov_turn, self._changed, self._react, self._held, self._stim_consts)  # fmt: skip
        hits = (self.car_shift, self.car_half[0], self.car_half[1], tr.reach, tr.half, tr.hitting)
        stop = (self.off_road_limit, self.end_past_lead, bool(self.config.terminate_on_collision), trig.paused, self.collisions,
                self.collisions_seen)  # fmt: skip
        k_from = 0
        while k_from < self.repeat:
            k_to = min(self.repeat, k_from + TraceRing.BLOCK)
            block_a, block_b = ring.reserve(k_to - k_from) if ring is not None else (self._no_block, self._no_block)
            ring_t = (block_a, block_b, ring.g % ring.BLOCK - k_from if ring is not None else 0,
                      ring.steps if ring is not None else self._no_steps, self._pedals, ring is not None)  # fmt: skip
            steps, resume = k_from, False
            while True:
                pf, pp, pi = tr.paths.arrays()  # (afresh: a leg event in Python may rebuild them)
                traffic = (st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, tr.sp_packed, pf, pp, pi, self._ego3, tr.work,
                           tr.flags, tr.no_lights, self._brake_out, self._turn_out, self._net, self._quiet, tr.c, self._car_rows,
                           self._codes)  # fmt: skip
                args = (resume, k_from, k_to, self.dt, live, self._park, self._stage, self.step_count, controls, ego, traffic, trig_t,
                        timer_t, a, lead, lanes, ring_t, hook, self._band, stim, hits, stop)  # fmt: skip
                parked, ran, changed = platoon_substeps(*args) if self.parallel else _substeps_range(0, self.n, *args)
                steps = max(steps, int(ran))
                if timers.done.any():  # (before firing: a timer a trigger re-arms is scored first)
                    timers.score_ended(trig.started_at)
                if changed:
                    self._copy_changes()
                if not parked:
                    break
                for e in np.flatnonzero((self._park >= 0) & (self._stage == TRAFFIC)).tolist():
                    traffic_events(tr, e, int(self._codes[e]), self.dt, self.t, self._ego3)
                env = np.flatnonzero(trig.contact >= 0)
                if env.size:
                    trig.fire(self.t, env, trig.contact[env], self._run_action)
                resume = True
            if ring is not None:
                ring.g += steps - k_from
            if steps < k_to:  # every env stopped early
                break
            k_from = k_to

    def _copy_changes(self) -> None:
        """The stimulus results the pass changed, into their `Stimulus` records (flags cleared)."""
        for e, slot in zip(*np.nonzero(self._changed), strict=True):
            obj = self.objs[e][slot]
            assert obj is not None
            if self._changed[e, slot] == 2:
                obj.reaction_s = float(self._react[e, slot])
            obj.result = int(self.result[e, slot])
            if self.kind[e, slot] == SR:
                obj.hold_since_s = float(self._held[e, slot])
            self.dirty[e] = True
            self._changed[e, slot] = 0

    def _controls(self, actions: np.ndarray, stepping: np.ndarray) -> BatchControls:
        """`BatchActions.convert(actions, stepping)` in one compiled pass (`step_controls`),
        into arrays kept from step to step (no reader keeps them)."""
        try:
            a = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"actions must be numbers, got dtype {np.asarray(actions).dtype}") from None
        width = self.actions.width
        if a.shape != (self.n, width):
            raise ValueError(f"actions must have shape ({self.n}, {width}), got {a.shape}")
        a = a if a.flags.c_contiguous else np.ascontiguousarray(a)
        c = self._c
        controls = step_controls_parallel if self.parallel and self.n >= PARALLEL_CONTROLS_ENVS else step_controls
        bad = controls(a, stepping, self.actions.name == "continuous_buttons", self.actions.held, c.steer, c.gas, c.brake, c.pressed,
                       c.signal)  # fmt: skip
        if bad >= 0:
            raise ValueError(f"env {bad}: action contains NaN or infinity: {a[bad].tolist()}")
        return c

    # ------------------------------------------------------------------ outputs
    def step_and_reset(self, actions: np.ndarray, resetting: np.ndarray, size: int) -> StepArrays:
        """`shards.step_shard`'s step with NEXT_STEP autoreset: the envs not `resetting` step
        (one compiled pass, `_physics_steps`), the others reset, then one compiled pass
        (`platoon_finish`) writes every env's reward, flags, observation and info (a reset
        env's are those of its fresh state). The info arrays are rows of two blocks allocated
        per step (the caller may keep them). Returns (obs, reward, terminated, truncated,
        info, envs whose episode ended)."""
        stepping = ~resetting
        c = self._controls(actions, stepping)
        self._physics_steps(stepping.copy(), c)
        if resetting.any():
            self.reset_rows(np.flatnonzero(resetting), None)
        n, s, st, tm, g = self.n, self.s, self.traffic.st, self.timers, self.guide
        k = int(self.template.config.nearby_vehicles)
        stim_width = 7 if isinstance(self, BrakeBatch) else 6
        if size != len(EGO_NAMES) + k * len(VEHICLE_NAMES) + stim_width:
            raise ValueError(f"this observation has 7 ego features, {k} vehicle slots and {stim_width} stimulus values, not {size} values")
        reward, terminated, truncated = np.empty(n), np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        out = np.empty((n, size), dtype=np.float32)
        info_f, info_i, known = np.empty((len(INFO_F), n)), np.empty((len(INFO_I), n), dtype=np.int64), np.empty(n, dtype=bool)
        rl = self.rl
        outcome = (stepping, g.sign, g.start_xz[1], s.x, s.z, s.yaw, s.u, self.last_s, self.progress, self.collisions, self.collisions_seen,
                   self.new_collisions, tm.n_results, self.reaction_cursor, tm.last_result, tm.last_rt, rl["n"], rl["m2"], rl["dist"],
                   rl["area"], self.t, s.fuel_used, self.offset, self.lane, self.headway, self.ttc, self.lat, self.trig.paused,
                   bool(self.config.terminate_on_collision), float(self.config.max_episode_s), reward, terminated, truncated)  # fmt: skip
        brake_test = isinstance(self, BrakeBatch)
        reward_t = (self.reward_acc, float(self.progress_per_m), float(self.off_road_limit), float(self.off_road_penalty),
                    self.end_past_lead, float(self.collision_penalty), *self._bonuses(), brake_test,
                    float(self.template.config.reward_sign_reaction) if brake_test else 0.0)  # fmt: skip
        obs = (out, g.road_heading, self.offset, self.lat, self.lane, s.steer_in, s.r, k, self._ego4)
        tr = self.traffic
        stim = (st.pos, st.yaw, st.speed, st.enabled, st.i, st.b, self._brake_out, self._turn_out, tr.c, self.lead_i, self.follow_i,
                bool(self.with_follower), self.lead_j, self.lead_gap, self.lead_v, *self._signs())  # fmt: skip
        args = (outcome, reward_t, obs, stim, info_f, info_i, known, bool(g.lanes_known))
        if self.parallel:
            with numba.parallel_chunksize(1):
                platoon_finish(*args)
        else:
            _finish_range(0, n, *args)
        info = dict(zip(INFO_F, info_f)) | dict(zip(INFO_I, info_i))
        info["lanes_known"] = known
        info = {key: info[key] for key in INFO_KEYS}
        return out, reward, terminated, truncated, info, np.flatnonzero(terminated | truncated).tolist()

    def _bonuses(self) -> tuple[np.ndarray, np.ndarray]:
        """The stimulus results each env's reward adds this step (+1 correct, -1 otherwise), in
        the order of its stimuli (`_reward`'s loop), and their number per env."""
        self._n_bonus[:] = 0
        for e in np.flatnonzero(self.dirty).tolist():
            results = [st.result for st in self.stimuli[e] if st.result != 0]
            new = results[int(self.seen[e]) :]
            if len(new) > self._bonus.shape[1]:
                grown = np.zeros((self.n, 2 * len(new)))
                grown[:, : self._bonus.shape[1]] = self._bonus
                self._bonus = grown
            self._bonus[e, : len(new)] = [1.0 if res == 1 else -1.0 for res in new]
            self._n_bonus[e] = len(new)
            self.seen[e] = len(results)
        self.dirty[:] = False
        return self._bonus, self._n_bonus

    def _signs(self) -> tuple[np.ndarray, np.ndarray]:
        """The brake test's signs for the observation: (revealed per env, their z); none here."""
        return self._no_signs, self._no_sign_z

    def _stimulus(self) -> np.ndarray:
        c = self.traffic.c
        brake, turn = self.traffic.outputs()
        found = self.lead_j >= 0
        li = np.arange(self.n) * c + self.lead_i
        fi = np.arange(self.n) * c + self.follow_i
        cols = [
            np.where(found, self.lead_gap, 0.0),
            np.where(found, self.lead_v - self.s.u, 0.0),
            brake[li].astype(float),
            turn[li].astype(float),
            -self._distance_to(self.follow_i) if self.with_follower else np.zeros(self.n),
            turn[fi].astype(float) if self.with_follower else np.zeros(self.n),
        ]
        return np.stack(cols, axis=1)

    def _task_terminated(self) -> np.ndarray:
        off = np.abs(self.lat) > self.off_road_limit
        return off | (self._distance_to(self.lead_i) < 0.0) if self.end_past_lead else off

    def _reward(self, info: dict[str, np.ndarray], terminated_task: np.ndarray) -> np.ndarray:
        r = self.reward_acc + self.progress_per_m * np.maximum(0.0, info["progress_m"])
        self.reward_acc = np.zeros(self.n)
        r = np.where(terminated_task, r - self.off_road_penalty, r)
        for e in np.flatnonzero(self.dirty).tolist():
            results = [s.result for s in self.stimuli[e] if s.result != 0]
            re = float(r[e])
            for res in results[int(self.seen[e]) :]:
                re += 1.0 if res == 1 else -1.0
            r[e] = re
            self.seen[e] = len(results)
        self.dirty[:] = False
        return r - self.collision_penalty * info["new_collisions"].astype(np.float64)

    def episodes_metrics(self, es: list[int]) -> list[tuple[int, dict[str, float]]]:
        """`episode_metrics` of the envs `es`, the same floats: `episodes_table`'s rows as dicts
        (turned into Python floats at once, NaNs as `math.nan`, as the single env's metrics hold
        them)."""
        tab = self.episodes_table(es)
        return [(e, dict(zip(tab.keys, row))) for e, row in zip(es, _rows_with_nan(tab.values), strict=True)]

    def episodes_table(self, es: list[int]) -> EpisodeTable:
        """`episode_metrics` of the envs `es` as one table (a row per episode, `episode_metrics`'
        keys in its order), computed in two compiled passes over all of them: the generic trace
        metrics (`metrics.episode_scores`) and the platoon metrics (`PlatoonCore.metrics`,
        `metrics.platoon_scores`). Only episodes with reaction timer results, and the brake
        test's episodes with brake trials (`_extra_table`), take Python of their own."""
        if self.ring is None:
            raise RuntimeError("episode metrics were switched off (record_metrics=False)")
        m = len(es)
        if not m:
            keys = _BASE_KEYS + scores.KEYS + self.extra_keys
            return EpisodeTable(keys, np.empty((0, len(keys))), None)
        starts, data = self.ring.gather(es, self.parallel)  # (column, row): the episodes one after another, reset rows first
        col = self.trace_columns.index
        g = self.guide
        if g.kind != "lanes":
            raise ValueError("the native batch needs a task with lane bands")
        off = np.empty(data.shape[1])  # each row's lane offset
        base = np.empty((m, len(episode_scores.KEYS)))
        args = (starts, data[col("x_m")], data[col("z_m")], data[col("steering")], data[col("speed_mps")], data[col("gap_m")],
                data[col("lead_speed_mps")], data[col("headway_s")], data[col("ttc_s")],
                (self.dt, g.sign, self.centres, g.lane_width_m / 2.0, STEERING_WHEEL_MAX_DEG), self._score_params, off, base)  # fmt: skip
        if self.parallel:
            with numba.parallel_chunksize(1):  # (episodes differ in length: threads take a chunk at a time)
                score_episodes(episode_chunks(m), *args)
        else:
            score_range(0, m, *args)
        steps = np.ones(len(off), dtype=bool)
        steps[starts[:-1]] = False  # (the reset row is no step of the platoon metrics)
        nb = len(_BASE_KEYS)
        table = np.empty((m, nb + len(scores.KEYS)))
        self._platoon_scores(es, data[col("lon_dev")][steps], off[steps], starts - np.arange(m + 1), table[:, nb:])
        idx = np.asarray(es, dtype=np.int64)
        reactions: dict[int, list[Any]] = {}
        counts = np.zeros((m, 5))  # reactions, correct, failed, missed, mean reaction time
        counts[:, 4] = math.nan
        for j in np.flatnonzero(self.timers.n_results[idx] > 0).tolist():  # (rare: episodes with reaction timers scored)
            e = es[j]
            rs = reactions[e] = self.timers.results_of(e)
            correct = [r for r in rs if r.result == 1]
            counts[j, :4] = len(rs), len(correct), sum(1 for r in rs if r.result == -1), sum(1 for r in rs if r.result == -2)
            counts[j, 4] = float(np.mean([r.reaction_time_s for r in correct])) if correct else math.nan
        tpl = self.template
        # `OpenDSEnv.episode_metrics`' keys in order (`_BASE_KEYS`), then `PlatoonCore.metrics`'
        parts = (self.t[idx], base[:, 0:2], self.s.fuel_used[idx], self.collisions[idx], base[:, 2:6], counts,
                 float(self.guide.lanes_known), base[:, 6:8], self._presented_rows(idx), base[:, 8], float(tpl.resets),
                 float(tpl.collision_resets), float(tpl.reset_time_s), base[:, 9:])  # fmt: skip
        at = 0
        for v in parts:
            a = np.asarray(v, dtype=np.float64)
            a = a.reshape(m, -1) if a.ndim else np.full((m, 1), a)
            table[:, at : at + a.shape[1]] = a
            at += a.shape[1]
        assert at == nb, "the columns above are `_BASE_KEYS`"
        if self.has_extra_metrics:
            table = np.concatenate([table, self._extra_table(es, idx, reactions, starts, data)], axis=1)
        return EpisodeTable(_BASE_KEYS + scores.KEYS + self.extra_keys, table, None)

    def _presented_rows(self, idx: np.ndarray) -> np.ndarray:
        """`_stimuli_presented` of the episodes of the envs `idx`."""
        return self.n_stimuli[idx].astype(np.float64)

    def _extra_table(self, es: list[int], idx: np.ndarray, reactions: dict[int, list[Any]], starts: np.ndarray,
                     data: np.ndarray) -> np.ndarray:  # fmt: skip
        """The task's own metrics after `PlatoonCore.metrics` (`extra_keys`' columns, a row per
        episode of `es`, envs `idx`; `reactions` their reaction timer results where any,
        `starts` and `data` their trace as `TraceRing.gather` returned it): none for the
        platoon test."""
        return np.empty((len(es), 0))

    def _platoon_scores(self, es: list[int], lon: np.ndarray, off: np.ndarray, starts: np.ndarray, out: np.ndarray) -> None:
        """`PlatoonCore.metrics` of the envs `es` into the rows of `out` (`scores.KEYS`' columns):
        lon[starts[j]:starts[j+1]] and off[...] are the longitudinal band deviations and lane
        offsets of env es[j]'s steps."""
        idx = np.asarray(es, dtype=np.int64)
        n_stim = self.n_stimuli[idx]
        stims = [s for e in idx[n_stim > 0].tolist() for s in self.stimuli[e]]
        stim_starts = np.zeros(len(es) + 1, dtype=np.int64)
        np.cumsum(n_stim, out=stim_starts[1:])
        kind = np.array([scores.KINDS.index(s.kind) for s in stims], dtype=np.int64)
        result = np.array([s.result for s in stims], dtype=np.int64)
        rt = np.array([s.reaction_time_s for s in stims], dtype=np.float64)
        onset = np.array([s.onset_s for s in stims], dtype=np.float64)
        lb = self.spec.lateral_tolerance
        lat_lo, lat_hi = (lb.lower_bound_m, lb.upper_bound_m) if lb is not None else (0.0, 0.0)
        block = np.empty((len(es), len(scores.KEYS)))
        scores.platoon_scores(lon, off, starts, float(lat_lo), float(lat_hi), lb is not None, kind, result, rt, onset, stim_starts,
                              self.t[idx], float(self.spec.max_reaction_time_s), block)  # fmt: skip
        out[:] = block

    def _load_episode(self, e: int, columns: np.ndarray | None) -> None:
        assert self.ring is not None
        platoon = self.template.platoon
        row = self._scored.get(e)
        if row is not None:  # scored already: the template's `PlatoonCore.metrics` returns them
            platoon.state = PlatoonState(stimuli=list(self.stimuli[e]))
            platoon.metrics = row.copy  # type: ignore[method-assign]
            return
        platoon.__dict__.pop("metrics", None)
        off = self.template.trace.col("lane_offset_m")[1:]  # (the episode's trace, loaded just before)
        lb = self.spec.lateral_tolerance
        lat = np.maximum(np.maximum(0.0, lb.lower_bound_m - off), off - lb.upper_bound_m) if lb is not None else np.zeros(0)
        lon = (self.ring.column(e, "lon_dev") if columns is None else columns[self.trace_columns.index("lon_dev")])[1:]
        platoon.state = PlatoonState(stimuli=list(self.stimuli[e]), lon_dev=list(lon), lat_dev=list(lat))


BRAKE_KINDS = ("brakeLight", "emergencyBrake")  # the stimuli `brake_metrics` scores


class BrakeBatch(PlatoonBatch):
    handled_actions = frozenset({"setTVPTStimulus", "manipulateObject", "setupBrakeReactionTimer"})
    trace_columns = PlatoonBatch.trace_columns + ("accelerator", "brake")
    has_extra_metrics = True

    def __init__(self, template: Any, n: int, record_metrics: bool = True) -> None:
        super().__init__(template, n, record_metrics)
        self.sign_ids = [oid for oid, objs in self.world.objects.by_id.items() if oid.endswith("_Sign")]
        self.sign_z = np.array([self.world.objects.by_id[oid][0].position[2] for oid in self.sign_ids])
        self.revealed = np.zeros((n, len(self.sign_ids)), dtype=bool)
        no_trials = brake_metrics(np.zeros(1), np.zeros(1), np.zeros(1), [], [], [], 0)  # (`brake_metrics` of an episode without any)
        self.extra_keys = tuple(no_trials)
        self._no_trial_row = np.array([no_trials[k] for k in self.extra_keys], dtype=np.float64)

    def _reset_task(self, idx: np.ndarray) -> None:
        super()._reset_task(idx)
        self.revealed[idx] = False

    def _load_episode(self, e: int, columns: np.ndarray | None) -> None:
        super()._load_episode(e, columns)
        self.template._shown = {oid for oid, shown in zip(self.sign_ids, self.revealed[e], strict=True) if shown}  # (signs revealed)

    def _on_action(self, e: int, act: CompiledAction, trigger: int) -> None:
        if act.name == "manipulateObject":
            oid = str(act.args["object_id"])
            if oid in self.sign_ids and act.args.get("visible"):
                self.revealed[e, self.sign_ids.index(oid)] = True
            return
        super()._on_action(e, act, trigger)

    def _presented_rows(self, idx: np.ndarray) -> np.ndarray:
        return super()._presented_rows(idx) + np.count_nonzero(self.revealed[idx], axis=1)

    def _extra_table(self, es: list[int], idx: np.ndarray, reactions: dict[int, list[Any]], starts: np.ndarray,
                     data: np.ndarray) -> np.ndarray:  # fmt: skip
        """`BrakeReactionEnv`'s own metrics (`envs.brake.brake_metrics`): those of an episode
        without a brake trial or a timer result (most) as a table; the others by
        `brake_metrics` (Python)."""
        shown = np.count_nonzero(self.revealed[idx], axis=1).astype(np.float64)
        out = np.empty((len(es), len(self.extra_keys)))
        out[:] = self._no_trial_row
        out[:, self.extra_keys.index("BrakeSign_unscored")] = shown  # (no reactions: max(0, shown - 0))
        col = self.trace_columns.index
        reset_t: list[float] | None = None
        for j in np.flatnonzero((self.n_brake_stimuli[idx] > 0) | (self.timers.n_results[idx] > 0)).tolist():
            e = es[j]
            if reset_t is None:
                reset_t = [ev.t_s for ev in self.world.events.since(0) if ev.kind == "reset"]
            columns = data[:, starts[j] : starts[j + 1]]
            t = np.arange(columns.shape[1]) * self.dt
            row = brake_metrics(t, columns[col("accelerator")], columns[col("brake")], self.stimuli[e], reactions.get(e, []), reset_t,
                                int(shown[j]))  # fmt: skip
            out[j] = [row[k] for k in self.extra_keys]
        return out

    def _signs(self) -> tuple[np.ndarray, np.ndarray]:
        return self.revealed, self.sign_z

    def _stimulus(self) -> np.ndarray:
        visible = np.any(self.revealed & (self.sign_z[None, :] < self.s.z[:, None]), axis=1)
        return np.concatenate([super()._stimulus(), visible[:, None].astype(float)], axis=1)

    def _reward(self, info: dict[str, np.ndarray], terminated_task: np.ndarray) -> np.ndarray:
        r = super()._reward(info, terminated_task)
        res = info["reaction_result"]
        bonus = self.template.config.reward_sign_reaction
        return np.where(res == 1, r + bonus, np.where(res < 0, r - bonus, r))
