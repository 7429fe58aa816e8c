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


def score_drt(onsets_s: Sequence[float], responses_s: Sequence[float], min_rt_s: float = 0.1, max_rt_s: float = 2.5) -> DrtScore:
    """ISO 17488: a response 100-2500 ms after onset is a hit; <100 ms premature; else miss.

    Each stimulus takes the first response in its window; a response is used once.
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
    return DrtScore(n, hits, n - hits, premature, hits / n if n else math.nan, float(np.mean(rts)) if rts else math.nan)
