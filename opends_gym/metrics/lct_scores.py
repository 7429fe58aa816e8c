"""The Lane Change Test's instructed-lane-change scoring of many episodes in one compiled pass.

Why: a native LCT batch under random actions ends 1-2 episodes per 1,000 env-steps, and
scoring each with `LaneChangeTestEnv.episode_metrics` cost ~350 µs of Python, a third of
the step. `episode_scores.episode_scores` computes the generic trace keys; the LCT scores
SAE J2944's SDLP and the steering reversal rates differently (`LaneChangeTestEnv.
_standard_metrics`): the samples of instructed lane changes (from a sign becoming readable
to the end of the basic normative change, `_instructed_changes`) are left out, and the
lateral position is measured from the instructed lane's centre. `lct_scores` computes those
keys and the sign counts (`signs_reached`, `_stimuli_presented`, the signs passed) with the
same floats as the numpy code (numpy's pairwise sums, the single env's filter).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .episode_scores import _filtered, _reversals, _sdlp
from .sums import np_sum

J2944 = 5  # sdlp_j2944_m, _valid_fraction, _excluded_fraction, _segments, _segments_valid (`episode_scores.KEYS[9:14]`)


@kernel
def lct_scores(starts: np.ndarray, t: np.ndarray, z: np.ndarray, lateral: np.ndarray, steer_deg: np.ndarray, start_z: float,
               sign_d: np.ndarray, sign_from: np.ndarray, sign_to: np.ndarray, visibility: float, start_before: float,
               per_lane: float, lane_lat: np.ndarray, initial_lane: int, b: np.ndarray, a: np.ndarray, zi: np.ndarray,
               p: np.ndarray, gaps: np.ndarray, out: np.ndarray) -> None:  # fmt: skip
    """For episodes j (rows starts[j]..starts[j+1]-1 of the trace columns, reset row first)
    into out[j]: SAE J2944 SDLP (5 values, `episode_scores.KEYS[9:14]`) and the steering
    reversal rates per gap over the samples outside instructed lane changes, then
    signs_reached, stimuli presented, signs passed (their d_m <= the last sample's).
    sign_*: `LaneChangeTestEnv.metric_signs` in track order; b..gaps from
    `episode_scores.scoring_params`."""
    fs, seg_len, min_valid, min_run, on = p[0], p[9], p[10], p[11], p[12] > 0.0
    total = len(t)
    keep = np.empty(total, dtype=np.bool_)  # outside every instructed lane change
    lane = np.empty(total, dtype=np.int64)
    y = np.empty(total)  # lateral position from the instructed lane's centre
    buf = np.empty(total)
    segs = np.empty(total)
    n_gaps = len(gaps)
    for j in range(len(starts) - 1):
        lo, hi = starts[j], starts[j + 1]
        n = hi - lo
        row = out[j]
        # the furthest point: start_z - min(z) (= max(d), rounding being monotonic; NaN if any is)
        furthest, nan = math.inf, False
        for i in range(lo, hi):
            if z[i] != z[i]:
                nan = True
            elif z[i] < furthest:
                furthest = z[i]
        furthest = math.nan if nan else start_z - furthest if n else -math.inf
        for i in range(lo, hi):
            keep[i] = True
            lane[i] = initial_lane
        reached, presented, passed = 0, 0, 0
        last = start_z - z[hi - 1] if n else math.nan
        for k in range(len(sign_d)):  # `_instructed_changes`, in track order
            start = sign_d[k] - visibility
            if sign_d[k] <= furthest:
                reached += 1
            if furthest >= start:
                presented += 1
            if sign_d[k] <= last:
                passed += 1
            if start > furthest:
                continue
            end = sign_d[k] - start_before + per_lane * abs(sign_to[k] - sign_from[k])
            top = end if end > start else start  # (Python's max(start, end))
            for i in range(lo, hi):
                di = start_z - z[i]
                if di >= start:
                    lane[i] = sign_to[k]
                    if di <= top:
                        keep[i] = False
        for i in range(lo, hi):
            y[i] = lateral[i] - lane_lat[lane[i]]
        # SDLP over fixed segments (`lateral.sdlp_segments` with the instructed changes excluded)
        n_seg, valid_segs, counted_all, ok_all = 0, 0, 0, 0
        for i in range(lo, hi):
            if keep[i]:
                counted_all += 1
                if math.isfinite(y[i]):
                    ok_all += 1
        if n >= 2:
            n_seg = int((t[hi - 1] - t[lo]) // seg_len)
            i0 = lo
            for k in range(n_seg):
                bound = t[lo] + seg_len * float(k + 1)
                i1 = i0
                while i1 < hi and t[i1] < bound:
                    i1 += 1
                cnt, good = 0, 0
                for i in range(i0, i1):
                    if keep[i]:
                        cnt += 1
                        if math.isfinite(y[i]):
                            good += 1
                value = math.nan
                if cnt and float(good) / cnt >= min_valid:
                    value = _sdlp(y, keep, i0, i1 - i0, buf)
                if math.isfinite(value):
                    segs[valid_segs] = value
                    valid_segs += 1
                i0 = i1
        row[0] = np_sum(segs, 0, valid_segs) / valid_segs if valid_segs else math.nan
        row[1] = float(ok_all) / counted_all if counted_all else math.nan
        row[2] = 1.0 - counted_all / n if n else math.nan
        row[3] = n_seg
        row[4] = valid_segs
        # steering reversal rates over the stretches outside instructed changes (`steering.reversal_rates`)
        counts = np.zeros(n_gaps, dtype=np.int64)
        duration = 0.0
        run = -1
        for i in range(lo, hi + 1):
            kk = keep[i] if i < hi else False
            if kk and run < 0:
                run = i
            elif not kk and run >= 0:
                if i - run >= min_run:
                    f = _filtered(b, a, zi, on, steer_deg, run, i - run)
                    for g in range(n_gaps):
                        counts[g] += _reversals(f, gaps[g])
                    duration += (i - run - 1) / fs
                run = -1
        for g in range(n_gaps):
            row[J2944 + g] = counts[g] / (duration / 60.0) if duration > 0.0 else math.nan
        row[J2944 + n_gaps] = reached
        row[J2944 + n_gaps + 1] = presented
        row[J2944 + n_gaps + 2] = passed
