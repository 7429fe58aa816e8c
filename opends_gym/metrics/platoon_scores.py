"""The platoon/brake tests' band and stimulus metrics of many episodes in one compiled pass.

Why: a native platoon or brake batch under random actions ends ~130 episodes per 1,000
env-steps, and scoring each in Python (`PlatoonCore.metrics`) cost more than stepping it.
`platoon_scores` computes the same 23 metrics for all envs that ended on one step at once.
The floats are the same as `PlatoonCore.metrics`'s: means are numpy's sums (`np_sum`
reproduces numpy's pairwise summation order), maxima follow `np.max`'s NaN rule, and the
fractions are counts divided by lengths, as `np.mean` of a boolean array computes them.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .sums import np_sum

KINDS = ("brakeLight", "leadingCarTurnSignal", "followerCarTurnSignal", "speedReduction", "emergencyBrake")
KEYS: tuple[str, ...] = (
    "longitudinal_deviation_mean_m",
    "longitudinal_deviation_max_m",
    "longitudinal_outside_fraction",
    "lateral_deviation_mean_m",
    "lateral_outside_fraction",
    *(f"{kind}_{what}" for kind in KINDS for what in ("n", "misses", "mean_rt_s")),
    "stimuli",
    "stimulus_misses",
    "stimulus_mean_rt_s",
)  # (the key order of `PlatoonCore.metrics`)


@kernel
def platoon_scores(lon: np.ndarray, off: np.ndarray, starts: np.ndarray, lat_lo: float, lat_hi: float, has_lat: bool, kind: np.ndarray,
                   result: np.ndarray, rt: np.ndarray, onset: np.ndarray, stim_starts: np.ndarray, t_end: np.ndarray, max_rt: float,
                   out: np.ndarray) -> None:  # fmt: skip
    """`PlatoonCore.metrics` of episodes j = 0..m-1 into out[j] (in `KEYS` order).

    lon[starts[j]:starts[j+1]]: episode j's longitudinal band deviations, one per step;
    off[...]: its lane offsets (the lateral deviation is taken from them as
    `PlatoonBatch._load_episode` does; `has_lat` False: no lateral band, no samples);
    kind/result/rt/onset[stim_starts[j]:stim_starts[j+1]]: its stimuli in order of onset (kind:
    an index into `KINDS`; result 1 correct, -2 missed, 0 unscored; rt: reaction time; onset
    time); t_end[j]: the episode's clock at its end. A stimulus counts as missed when its
    result is -2 or it is unscored and its reaction window (`max_rt`) is over by t_end."""
    m = len(starts) - 1
    lat = np.empty(len(off))
    picked = np.empty(len(rt))
    for j in range(m):
        lo, n = starts[j], starts[j + 1] - starts[j]
        row = out[j]
        if n > 0:
            big, outside = lon[lo], 0
            for i in range(lo, lo + n):
                v = lon[i]
                if not (big >= v or math.isnan(big)):
                    big = v
                if v > 0.0:
                    outside += 1
            row[0] = np_sum(lon, lo, n) / n
            row[1] = big
            row[2] = outside / n
        else:
            row[0] = row[1] = row[2] = math.nan
        nl = n if has_lat else 0
        if nl > 0:
            outside = 0
            for i in range(lo, lo + nl):
                a, b = lat_lo - off[i], off[i] - lat_hi
                u = 0.0 if a <= 0.0 else a  # np.maximum(np.maximum(0.0, a), b), NaNs included
                v = u if (u >= b or math.isnan(u)) else b
                lat[i] = v
                if v > 0.0:
                    outside += 1
            row[3] = np_sum(lat, lo, nl) / nl
            row[4] = outside / nl
        else:
            row[3] = row[4] = math.nan
        s0, s1 = stim_starts[j], stim_starts[j + 1]
        for k in range(len(KINDS)):
            count, misses, hits = 0, 0, 0
            for i in range(s0, s1):
                if kind[i] == k:
                    count += 1
                    if result[i] == -2 or (result[i] == 0 and t_end[j] - onset[i] > max_rt):
                        misses += 1
                    elif result[i] == 1:
                        picked[s0 + hits] = rt[i]
                        hits += 1
            row[5 + 3 * k] = count
            row[6 + 3 * k] = misses
            row[7 + 3 * k] = np_sum(picked, s0, hits) / hits if hits else math.nan
        misses, hits = 0, 0
        for i in range(s0, s1):
            if result[i] == -2 or (result[i] == 0 and t_end[j] - onset[i] > max_rt):
                misses += 1
            elif result[i] == 1:
                picked[s0 + hits] = rt[i]
                hits += 1
        row[20] = s1 - s0
        row[21] = misses
        row[22] = np_sum(picked, s0, hits) / hits if hits else math.nan
