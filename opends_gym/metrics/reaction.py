"""Reaction measures: OpenDS timer results by group, brake reaction time, DRT scoring.

Why: the same functions score a live episode, a recording and a human session. Times are
simulation seconds; OpenDS's codes are kept (1 correct, -1 failure, -2 missed).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

CORRECT, FAILURE, MISSED = 1, -1, -2


@dataclass(frozen=True)
class GroupSummary:
    group: str
    n: int
    correct: int
    failures: int
    misses: int
    mean_rt_s: float  # over correct reactions

    @property
    def hit_rate(self) -> float:
        return self.correct / self.n if self.n else math.nan


def summarize_reactions(results: Iterable[tuple[str, int, float]]) -> dict[str, GroupSummary]:
    """Per reaction group: counts by result and the mean reaction time of correct ones."""
    groups: dict[str, list[tuple[int, float]]] = {}
    for group, result, rt in results:
        groups.setdefault(group, []).append((int(result), float(rt)))
    out = {}
    for g, rows in groups.items():
        rts = [rt for r, rt in rows if r == CORRECT and math.isfinite(rt)]
        out[g] = GroupSummary(
            group=g,
            n=len(rows),
            correct=sum(1 for r, _ in rows if r == CORRECT),
            failures=sum(1 for r, _ in rows if r == FAILURE),
            misses=sum(1 for r, _ in rows if r == MISSED),
            mean_rt_s=float(np.mean(rts)) if rts else math.nan,
        )
    return out


def crossing_time(t: np.ndarray, x: np.ndarray, threshold: float, after_s: float) -> float:
    """First time after `after_s` that x reaches `threshold`, linearly interpolated (s)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    idx = np.flatnonzero((t >= after_s) & (x >= threshold))
    if len(idx) == 0:
        return math.nan
    k = int(idx[0])
    if k == 0 or t[k - 1] < after_s or x[k - 1] >= threshold:
        return float(t[k])
    f = (threshold - x[k - 1]) / (x[k] - x[k - 1])
    return float(t[k - 1] + f * (t[k] - t[k - 1]))


@dataclass(frozen=True)
class BrakeReaction:
    accelerator_release_s: float  # perception-reaction time: gas released
    brake_onset_s: float  # brake pedal beyond the threshold (full brake reaction time)


def brake_reaction_time(
    t: np.ndarray, accelerator: np.ndarray, brake: np.ndarray, stimulus_s: float, brake_threshold: float = 0.1
) -> BrakeReaction:
    """Times from a stimulus to gas release and to brake onset (NaN if they never happen)."""
    t = np.asarray(t, dtype=float)
    acc = np.asarray(accelerator, dtype=float)
    rel = np.flatnonzero((t >= stimulus_s) & (acc <= 0.0))
    release = float(t[rel[0]]) - stimulus_s if len(rel) else math.nan
    onset = crossing_time(t, brake, brake_threshold, stimulus_s)
    return BrakeReaction(release, onset - stimulus_s if math.isfinite(onset) else math.nan)


@dataclass(frozen=True)
class DrtScore:
    stimuli: int
    hits: int
    misses: int
    premature: int
    hit_rate: float
    mean_rt_s: float
    false_alarms: int = 0  # responses that answered no stimulus (neither hit nor premature)
    rts_s: tuple[float, ...] = ()  # the hits' reaction times, in stimulus order


def score_drt(onsets_s: Sequence[float], responses_s: Sequence[float], min_rt_s: float = 0.1, max_rt_s: float = 2.5) -> DrtScore:
    """ISO 17488: a response 100-2500 ms after onset is a hit; <100 ms premature; else miss.

    Each stimulus takes the first response in its window; a response is used once. A
    response that is neither a hit nor premature (before the first stimulus, after a
    stimulus's window, or a second press for an answered stimulus) is a false alarm.
    """
    responses = sorted(responses_s)
    used = [False] * len(responses)
    hits, premature, rts = 0, 0, []
    for onset in sorted(onsets_s):
        for j, r in enumerate(responses):
            if used[j] or r < onset:
                continue
            rt = r - onset
            if rt < min_rt_s:
                used[j] = True
                premature += 1
                continue
            if rt <= max_rt_s:
                used[j] = True
                hits += 1
                rts.append(rt)
            break
    n = len(onsets_s)
    return DrtScore(
        n, hits, n - hits, premature, hits / n if n else math.nan, float(np.mean(rts)) if rts else math.nan, used.count(False), tuple(rts)
    )


@dataclass(frozen=True)
class RtDistribution:
    """Reaction times of the answered trials: count, mean, SD (n - 1), median, percentiles."""

    n: int
    mean_s: float
    sd_s: float
    median_s: float
    p15_s: float
    p85_s: float

    @staticmethod
    def of(rts: Sequence[float]) -> RtDistribution:
        v = np.asarray([r for r in rts if math.isfinite(r)], dtype=float)
        if len(v) == 0:
            return RtDistribution(0, math.nan, math.nan, math.nan, math.nan, math.nan)
        sd = float(np.std(v, ddof=1)) if len(v) > 1 else math.nan
        p15, p50, p85 = (float(x) for x in np.percentile(v, [15.0, 50.0, 85.0]))
        return RtDistribution(len(v), float(v.mean()), sd, p50, p15, p85)


# Why these defaults: a lead-car stimulus of the Three-Vehicle Platoon Task must be
# answered within 5 s (`envs.platoon_core`, OpenDS-CTS's TVPT); the foot counts as on the
# accelerator above 5 % travel, and the brake as pressed at OpenDS's brake-light threshold
# of 10 % (`brake_reaction_time`'s `brake_threshold`). The 5 % is our choice.
BRAKE_MAX_WINDOW_S = 5.0
ACCELERATOR_ON = 0.05


@dataclass(frozen=True)
class BrakeTrial:
    stimulus_s: float
    valid: bool  # the foot was on the accelerator (and off the brake) at onset
    responded: bool  # brake onset within the window
    accelerator_release_s: float  # NaN unless valid and released within the window
    brake_onset_s: float  # the brake reaction time; NaN unless valid and responded


@dataclass(frozen=True)
class BrakeRtSummary:
    trials: int
    invalid: int  # foot not on the accelerator at onset: no reaction time can be measured
    responses: int
    misses: int  # valid trials without brake onset inside the window (counted, not dropped)
    miss_rate: float  # misses / valid trials
    rt: RtDistribution  # of the brake onset times of the responses
    release: RtDistribution  # of the accelerator release times


def score_brake_trials(
    t: np.ndarray,
    accelerator: np.ndarray,
    brake: np.ndarray,
    stimuli_s: Sequence[float],
    max_window_s: float = BRAKE_MAX_WINDOW_S,
    accelerator_on: float = ACCELERATOR_ON,
    brake_threshold: float = 0.1,
) -> tuple[list[BrakeTrial], BrakeRtSummary]:
    """Brake reaction trials scored as in the perception-response-time literature (Green
    2000; Olson & Sivak 1986 measured from the foot on the accelerator): a trial is valid
    only if, at stimulus onset, the accelerator is pressed (> `accelerator_on`) and the
    brake is not (a driver already braking would score ~0 s); a valid trial without brake
    onset within `max_window_s` is a miss, reported and not dropped from the counts."""
    t = np.asarray(t, dtype=float)
    acc = np.asarray(accelerator, dtype=float)
    brk = np.asarray(brake, dtype=float)
    trials: list[BrakeTrial] = []
    for onset in stimuli_s:
        k = int(np.searchsorted(t, onset, side="right")) - 1  # the sample in force at onset
        if k < 0:
            k = 0
        valid = len(t) > 0 and acc[k] > accelerator_on and brk[k] < brake_threshold
        if not valid:
            trials.append(BrakeTrial(float(onset), False, False, math.nan, math.nan))
            continue
        b = brake_reaction_time(t, acc, brk, float(onset), brake_threshold)
        responded = math.isfinite(b.brake_onset_s) and b.brake_onset_s <= max_window_s
        rel = b.accelerator_release_s
        release = rel if math.isfinite(rel) and rel <= max_window_s else math.nan
        trials.append(BrakeTrial(float(onset), True, responded, release, b.brake_onset_s if responded else math.nan))
    valid_n = sum(1 for tr in trials if tr.valid)
    responses = sum(1 for tr in trials if tr.responded)
    misses = valid_n - responses
    summary = BrakeRtSummary(
        trials=len(trials),
        invalid=len(trials) - valid_n,
        responses=responses,
        misses=misses,
        miss_rate=misses / valid_n if valid_n else math.nan,
        rt=RtDistribution.of([tr.brake_onset_s for tr in trials if tr.responded]),
        release=RtDistribution.of([tr.accelerator_release_s for tr in trials]),
    )
    return trials, summary
