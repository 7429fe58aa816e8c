"""Lane-change and brake reaction timers of a native batch (one timer id per task).

Why: `sim.triggers.reactions` (LaneChangeTimer, BrakeTimer) and `ReactionCenter` for N
envs, with the same OpenDS semantics (docs/reaction-timers.md): the per-step checks
(steering peak, limits, forbidden action, held lane or speed) run in a compiled loop over
the envs whose trial runs; setups and scoring are rare and run per env, building the same
`ReactionResult` records (times rounded to the nanosecond, as there). Each env keeps its
timer object's state as OpenDS does: the hold clock survives from one trial to the next
unless a setup of the other kind replaces the timer. A failed setup's sound timer makes no
result, so it is not kept. The optional extra timestamps of a result (`extra`: first
steering, lane entry, ...) are not kept: no env output reads them. The native batch runs
on flat ground only, so the 3-D distance limit is the distance in the ground plane.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..sim.road import LANE_MARGIN_M
from ..sim.triggers.reactions import CORRECT, EPS, FAILURE, MISSED, MISSED_RT_S, ReactionResult
from .kernels import FAIL as FAIL_
from .kernels import MISS as MISS_
from .kernels import N_TABLE, update_timers

LANE, BRAKE = 0, 1
KINDS = {"setupLaneChangeReactionTimer": LANE, "setupBrakeReactionTimer": BRAKE}


@dataclass(frozen=True)
class TimerSpec:
    """One setup*ReactionTimer action's arguments, as `ReactionCenter._build` reads them."""

    kind: int
    timer_id: str
    group: str
    comment: str
    time_limit_s: float
    distance_limit_m: float
    start_lane: int  # lane index (-2: not a lane of the road)
    target_lane: int
    min_steering: float  # raw steering wheel state
    allow_brake: bool
    hold_s: float
    target_speed_mps: float
    start_speed_mps: float
    must_press_brake: bool
    allow_lane_change: bool

    @staticmethod
    def from_args(name: str, a: dict[str, Any], lane_ids: tuple[str, ...]) -> TimerSpec:
        kind = KINDS[name]

        def lane(key: str) -> int:
            value = str(a.get(key) or "")
            return lane_ids.index(value) if value in lane_ids else -2

        return TimerSpec(
            kind=kind,
            timer_id=str(a["timer_id"]),
            group=str(a.get("reaction_group") or ""),
            comment=str(a.get("comment") or ""),
            time_limit_s=float(a.get("time_limit_s") or 0.0),
            distance_limit_m=float(a.get("distance_limit_m") or 0.0),
            start_lane=lane("start_lane"),
            target_lane=lane("target_lane"),
            min_steering=float(a.get("min_steering_angle") or 0.0),
            allow_brake=bool(a.get("allow_brake", True)),
            hold_s=float(a.get("hold_lane_for_s", 2.0)) if kind == LANE else float(a.get("hold_speed_for_s", 2.0)),
            target_speed_mps=float(a.get("target_speed_mps", 60.0 / 3.6)),
            start_speed_mps=float(a.get("start_speed_mps", 80.0 / 3.6)),
            must_press_brake=bool(a.get("must_press_brake_pedal", True)),
            allow_lane_change=bool(a.get("allow_lane_change", True)),
        )


def lane_index_at(x: np.ndarray, bands: tuple[tuple[float, float], ...], margin_m: float = LANE_MARGIN_M) -> np.ndarray:
    """`RoadModel.lane_id_at` as an index into the road's lanes (-1: none)."""
    out = np.full(x.shape, -1, dtype=np.int64)
    for i, (lo, hi) in enumerate(bands):
        out = np.where((out < 0) & (lo + margin_m <= x) & (x <= hi - margin_m), i, out)
    return out


class TimerBatch:
    """The running timer (at most one: the task's timer id) of each of N envs, and the results."""

    def __init__(self, n: int, bands: tuple[tuple[float, float], ...]) -> None:
        self.bands = bands
        self.specs: list[TimerSpec] = []
        self._spec_index: dict[int, int] = {}
        self.timer_ids: set[str] = set()
        self.active = np.zeros(n, dtype=bool)  # a trial runs (timerIsActive)
        self.kind = np.full(n, -1, dtype=np.int64)  # the kind of the env's timer object (-1: none yet)
        self.spec = np.zeros(n, dtype=np.int64)  # the spec of the running (or last) trial
        self.armed_t = np.zeros(n)  # when the trial was set up (misses are logged from it)
        self.start_t = np.zeros(n)  # startTime, startPosition and the limits: a failed setup
        self.start_x = np.zeros(n)  # overwrites them
        self.start_z = np.zeros(n)
        self.tlim = np.zeros(n)
        self.dlim = np.zeros(n)
        self.peak = np.zeros(n)
        self.hold_since = np.full(n, np.nan)  # the hold clock (NaN: not set)
        self.braked = np.zeros(n, dtype=bool)
        self.start_lane = np.full(n, -1, dtype=np.int64)
        self.results: list[list[tuple[int, int, float, float, float, float]]] = [[] for _ in range(n)]  # see `_score`
        self.n_results = np.zeros(n, dtype=np.int64)
        # each env's results this episode as arrays too (code, reaction time rounded to the ns, spec), for the compiled
        # episode scoring (`lct_score_pass`): columns 0..n_results-1; widened when an episode logs more
        self.result_code = np.zeros((n, 4), dtype=np.int64)
        self.result_rt = np.zeros((n, 4))
        self.result_spec = np.zeros((n, 4), dtype=np.int64)
        self.sign_of_spec = np.zeros(0, dtype=np.int64)  # the sign number in each spec's comment ('sign NN: ...'; -1: none)
        self.last_result = np.zeros(n)  # the latest result's code and reaction time (s)
        self.last_rt = np.zeros(n)  # (rounded to the nanosecond, as ReactionResult)
        self.table = np.zeros((0, N_TABLE))  # one row per spec (columns `kernels.T_*`)
        self.band_table = np.array(bands, dtype=np.float64).reshape(-1, 2)
        self.done = np.zeros(n, dtype=np.int64)  # how each env's timer ended this step (`kernels.FAIL` ...; 0: it did not)
        self.done_t = np.zeros(n)  # when

    def add_spec(self, key: int, name: str, args: dict[str, Any], lane_ids: tuple[str, ...]) -> None:
        spec = TimerSpec.from_args(name, args, lane_ids)
        self.timer_ids.add(spec.timer_id)
        if len(self.timer_ids) > 1:
            raise ValueError(f"the native batch supports one reaction timer id per task, not {sorted(self.timer_ids)}")
        self._spec_index[key] = len(self.specs)
        self.specs.append(spec)
        found = re.match(r"sign (\d+):", spec.comment or "")  # (`LaneChangeTestEnv._timer_results`' reading)
        self.sign_of_spec = np.append(self.sign_of_spec, int(found.group(1)) if found else -1)
        fields: tuple[str, ...] = ("kind", "time_limit_s", "distance_limit_m", "target_lane", "min_steering", "allow_brake")
        fields += ("hold_s", "target_speed_mps", "must_press_brake", "allow_lane_change")  # (in the order of `kernels.T_*`)
        self.table = np.array([[float(getattr(s, f)) for f in fields] for s in self.specs]).reshape(-1, N_TABLE)

    def reset_rows(self, idx: np.ndarray) -> None:
        """A new episode: a new ReactionCenter, no timer objects."""
        self.active[idx] = False
        self.kind[idx] = -1
        self.clear_results(idx)
        self.n_results[idx] = 0

    def clear_results(self, idx: np.ndarray) -> None:
        """`reset_rows`' part in Python: the results lists of the envs `idx` emptied (a compiled
        reset, `vector.lct_step`, does the rest)."""
        results = self.results
        for i in np.atleast_1d(idx).tolist():
            if results[i]:  # (replaced only when used: fewer objects for Python's garbage collector)
                results[i] = []

    # ------------------------------------------------------------------ arming (rare)
    def setup(self, es: np.ndarray, key: int, t: np.ndarray, x: np.ndarray, z: np.ndarray, u: np.ndarray, started_at: np.ndarray) -> None:
        """`ReactionCenter.setup` for the envs `es` (the caller checked that measurement
        started); t, x, z, u and started_at are theirs."""
        k = self._spec_index[key]
        spec = self.specs[k]
        other = self.kind[es] != spec.kind  # no timer object of this kind: close the old one, make a new one
        for i in np.flatnonzero(other & self.active[es]).tolist():
            self._miss(int(es[i]), float(t[i]), float(started_at[i]))
        fresh = es[other]
        self.kind[fresh] = spec.kind
        self.active[fresh] = False
        self.hold_since[fresh] = np.nan
        self.peak[fresh] = 0.0
        self.braked[fresh] = False
        if spec.kind == LANE:
            ok = lane_index_at(x, self.bands) == spec.start_lane
        else:
            ok = u >= spec.start_speed_mps - EPS
        for i in np.flatnonzero(ok & self.active[es]).tolist():  # ReactionTimer.setup: the running trial is a miss
            self._miss(int(es[i]), float(t[i]), float(started_at[i]))
        # both branches: start, position and limits (a failed setup keeps the running trial)
        self.start_t[es], self.start_x[es], self.start_z[es] = t, x, z
        self.tlim[es], self.dlim[es] = spec.time_limit_s, spec.distance_limit_m
        armed = es[ok]
        self.active[armed] = True
        self.spec[armed] = k
        self.armed_t[armed] = t[ok]
        self.peak[armed] = 0.0
        self.braked[armed] = False
        self.start_lane[armed] = lane_index_at(x[ok], self.bands, 0.0)  # (the brake timer's raw band)

    def _miss(self, e: int, t: float, started_at: float) -> None:
        self.active[e] = False
        self._score(e, MISSED, MISSED_RT_S, float(self.armed_t[e]), t, started_at)

    def _score(self, e: int, result: int, rt_s: float, start: float, t: float, started_at: float) -> None:
        """Log a result: as a plain tuple (the `ReactionResult` is built when asked for, by
        `results_of`: most are never read) and as env e's latest result and reaction time."""
        self.results[e].append((int(self.spec[e]), result, rt_s, start, t, started_at))
        k = int(self.n_results[e])
        if k == self.result_code.shape[1]:  # (rare: twice the columns)
            self.result_code = np.concatenate([self.result_code, np.zeros_like(self.result_code)], axis=1)
            self.result_rt = np.concatenate([self.result_rt, np.zeros_like(self.result_rt)], axis=1)
            self.result_spec = np.concatenate([self.result_spec, np.zeros_like(self.result_spec)], axis=1)
        self.result_code[e, k], self.result_rt[e, k], self.result_spec[e, k] = result, round(rt_s, 9), self.spec[e]
        self.n_results[e] += 1
        self.last_result[e], self.last_rt[e] = result, round(rt_s, 9)

    def results_of(self, e: int) -> list[ReactionResult]:
        """Env e's results this episode, as `ReactionCenter.results` holds them."""
        out = []
        for k, result, rt_s, start, t, started_at in self.results[e]:
            spec = self.specs[k]
            out.append(
                ReactionResult(
                    timer_id=spec.timer_id,
                    kind="laneChange" if spec.kind == LANE else "brake",
                    group=spec.group,
                    result=result,
                    reaction_time_s=round(rt_s, 9),
                    start_t_s=round(start, 9),
                    t_s=round(t, 9),
                    experiment_time_s=round(start - started_at, 9),
                    comment=spec.comment,
                )
            )
        return out

    # ------------------------------------------------------------------ polling
    def update(self, rows: np.ndarray, t: np.ndarray, x: np.ndarray, z: np.ndarray, u: np.ndarray, steer: np.ndarray, brake: np.ndarray,
               started_at: np.ndarray) -> None:  # fmt: skip
        """`ReactionCenter.update` for the envs `rows` (not paused): a compiled loop; the timers
        that end are scored here."""
        if not self.specs:
            return
        ended = update_timers(self.active, self.spec, self.start_t, self.start_x, self.start_z, self.tlim, self.dlim, self.peak,
                              self.hold_since, self.braked, self.start_lane, self.table, self.band_table, rows, t, x, z, u, steer, brake,
                              self.done, self.done_t)  # fmt: skip
        if ended:
            self.score_ended(started_at)

    def score_ended(self, started_at: np.ndarray) -> None:
        """Score the timers flagged in `done` (at their `done_t`) and clear the flags."""
        for e in np.flatnonzero(self.done).tolist():
            how = int(self.done[e])
            now = float(self.done_t[e])
            if how == MISS_:
                self._miss(e, now, float(started_at[e]))
            else:  # the reaction time leaves out the hold clock's run so far
                hold = float(self.hold_since[e])
                offset = now - hold if hold == hold else 0.0
                rt = now - float(self.start_t[e]) - offset
                self._score(e, FAILURE if how == FAIL_ else CORRECT, rt, float(self.start_t[e]), now, float(started_at[e]))
            self.active[e] = False
            self.done[e] = 0
