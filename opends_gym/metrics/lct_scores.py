"""The Lane Change Test's instructed-lane-change scoring of many episodes in one compiled pass.

Why: a native LCT batch under random actions ends 1-2 episodes per 1,000 env-steps, and
scoring each with `LaneChangeTestEnv.episode_metrics` cost ~350 µs of Python, a third of
the step. `episode_scores.episode_scores` computes the generic trace keys; the LCT scores
SAE J2944's SDLP and the steering reversal rates differently (`LaneChangeTestEnv.
_standard_metrics`): the samples of instructed lane changes (from a sign becoming readable
to the end of the basic normative change, `_instructed_changes`) are left out, and the
lateral position is measured from the instructed lane's centre. `lct_scores` computes those
keys and the sign counts (`signs_reached`, `_stimuli_presented`, the signs passed);
`lct_lane_changes` the lane-change fits and MDEV of the episodes that passed a sign
(`metrics.lct`'s `fit_lane_changes`, `fit_adapted_model`, `normative_path`,
`mean_deviation`). The same floats as the numpy code (numpy's pairwise sums and medians,
the single env's filter, Python's `max` where it takes one).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import inline, kernel
from .episode_scores import j2944_segments, reversal_rates_into
from .lct import first_above, first_not_below
from .sums import np_sum

J2944 = 5  # sdlp_j2944_m, _valid_fraction, _excluded_fraction, _segments, _segments_valid (`episode_scores.KEYS[9:14]`)


@inline
def _never_decreases(d: np.ndarray, lo: int, hi: int) -> bool:
    """d[lo:hi] never decreases (and holds no NaN): then the rows of any window [a, b] of it
    are a slice, found by `lct.first_not_below` and `lct.first_above` (`lct._never_decreases`)."""
    for i in range(lo + 1, hi):  # noqa: SIM110  (numba compiles no generators)
        if not d[i] >= d[i - 1]:
            return False
    return True


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
    mark = np.empty(total, dtype=np.int64)  # the last sign whose rows begin at each row (-1: none)
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
        for i in range(lo, hi):
            buf[i] = start_z - z[i]  # d of each row
        sliced = _never_decreases(buf, lo, hi)
        for i in range(lo, hi):
            mark[i] = -1
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
            if sliced:  # (the usual drive) the rows from i0 on have d >= start; those to i1 also d <= top
                i0 = first_not_below(buf, lo, hi, start)
                if i0 < hi and buf[i0] >= start:
                    mark[i0] = k  # (each row's lane: the last sign whose rows began at or before it, below)
                for i in range(i0, first_above(buf, i0, hi, top)):
                    if buf[i] >= start and buf[i] <= top:
                        keep[i] = False
                continue
            for i in range(lo, hi):
                di = buf[i]
                if di >= start:
                    lane[i] = sign_to[k]
                    if di <= top:
                        keep[i] = False
        if sliced:
            latest = -1
            for i in range(lo, hi):
                latest = mark[i] if mark[i] > latest else latest
                lane[i] = sign_to[latest] if latest >= 0 else initial_lane
        for i in range(lo, hi):
            y[i] = lateral[i] - lane_lat[lane[i]]
        # SDLP over fixed segments (`lateral.sdlp_segments` with the instructed changes excluded)
        counted_all, ok_all = 0, 0
        for i in range(lo, hi):
            if keep[i]:
                counted_all += 1
                if math.isfinite(y[i]):
                    ok_all += 1
        n_seg, valid_segs = j2944_segments(t, y, keep, lo, hi, seg_len, min_valid, segs, buf)
        row[0] = np_sum(segs, 0, valid_segs) / valid_segs if valid_segs else math.nan
        row[1] = float(ok_all) / counted_all if counted_all else math.nan
        row[2] = 1.0 - counted_all / n if n else math.nan
        row[3] = n_seg
        row[4] = valid_segs
        # steering reversal rates over the stretches outside instructed changes (`steering.reversal_rates`)
        reversal_rates_into(row, J2944, keep, lo, hi, min_run, fs, b, a, zi, on, steer_deg, gaps)
        row[J2944 + n_gaps] = reached
        row[J2944 + n_gaps + 1] = presented
        row[J2944 + n_gaps + 2] = passed


@kernel
def _normative(d: np.ndarray, lo: int, hi: int, sign_d: np.ndarray, sign_from: np.ndarray, sign_to: np.ndarray, signs: int,
               lane_lat: np.ndarray, initial_lane: int, start_before: float, per_lane: float, offset: float,
               out: np.ndarray) -> None:  # fmt: skip
    """`lct.normative_path(d[lo:hi], the first `signs` signs, ...)` into out[lo:hi] (signs in
    track order: their starts are in order, `lct._ramps`; were they not, each row takes the
    last sign whose start is at or before it, as `normative_path` does then)."""
    starts = np.empty(signs)
    for s in range(signs):
        starts[s] = sign_d[s] - start_before
    ordered = _never_decreases(starts, 0, signs)
    walk = ordered and _never_decreases(d, lo, hi)  # (the usual drive: the count below only grows from row to row)
    a = 0
    for i in range(lo, hi):
        di = d[i]
        y = float(lane_lat[initial_lane])
        k = -1
        if walk:  # the number of starts <= di, counted on from the row before
            while a < signs and starts[a] <= di:
                a += 1
            k = a - 1
        elif ordered:  # ... by bisection (np.searchsorted, side 'right')
            k = first_above(starts, 0, signs, di) - 1
        else:
            for s in range(signs):  # (the last start <= di)
                if starts[s] <= di:
                    k = s
        if k >= 0 and not math.isnan(di):
            start = sign_d[k] - start_before
            length = per_lane * abs(sign_to[k] - sign_from[k])
            end = start + (1e-6 if length < 1e-6 else length)  # (Python's max(length, 1e-6))
            ramp = (di - start) / (end - start)
            ramp = 0.0 if ramp < 0.0 else 1.0 if ramp > 1.0 else ramp
            y_from, y_to = float(lane_lat[sign_from[k]]), float(lane_lat[sign_to[k]])
            y = y_from + ramp * (y_to - y_from)
        out[i] = y + offset


@kernel
def _mean_deviation(d: np.ndarray, y: np.ndarray, yn: np.ndarray, lo: int, hi: int, buf: np.ndarray) -> float:
    """`lct.mean_deviation(d[lo:hi], y[lo:hi], yn[lo:hi])`."""
    if hi - lo < 2 or d[hi - 1] <= d[lo]:
        return math.nan
    for i in range(lo, hi - 1):
        a, b = abs(y[i + 1] - yn[i + 1]), abs(y[i] - yn[i])
        buf[i - lo] = 0.5 * (a + b) * (d[i + 1] - d[i])
    return np_sum(buf, 0, hi - lo - 1) / (d[hi - 1] - d[lo])


@kernel
def lct_lane_changes(starts: np.ndarray, z: np.ndarray, lateral: np.ndarray, start_z: float, sign_d: np.ndarray,
                     sign_from: np.ndarray, sign_to: np.ndarray, passed: np.ndarray, visibility: float, start_before: float,
                     per_lane: float, lane_lat: np.ndarray, initial_lane: int, out: np.ndarray, fits: np.ndarray) -> None:  # fmt: skip
    """The LCT's lane-change scores of episodes j (rows starts[j]..starts[j+1]-1, no resets)
    that passed passed[j] > 0 signs (`LaneChangeTestEnv._episode_metrics`): out[j] = MDEV
    against the basic and the adapted model and the adapted model's start before the sign,
    length per lane and habitual offset (`lct.lct_mdev`; NaN where it is not scored); fits[j, k]
    = sign k's latency (m) and reached-target flag (`lct.fit_lane_changes`)."""
    total = len(z)
    d = np.empty(total)
    yb = np.empty(total)
    buf = np.empty(total)
    keeping = np.empty(total, dtype=np.bool_)
    for i in range(total):
        d[i] = start_z - z[i]
    n_signs = len(sign_d)
    f_start = np.empty(n_signs)
    f_len = np.empty(n_signs)
    for j in range(len(starts) - 1):
        lo, hi, p = starts[j], starts[j + 1], passed[j]
        if p == 0:
            continue
        last = d[hi - 1]
        n_fit = 0
        sliced = _never_decreases(d, lo, hi)  # (the usual drive: each window's rows are a slice)
        for k in range(p):  # `fit_lane_changes` (each window as `d`'s mask: a sorted search's slice where d never decreases)
            w0 = sign_d[k] - visibility
            w1 = sign_d[k + 1] - visibility if k + 1 < p else last
            y_from, y_to = float(lane_lat[sign_from[k]]), float(lane_lat[sign_to[k]])
            shift = y_to - y_from
            near = 0.5 * abs(shift) * 0.5
            i10, i90, reached, empty = -1, -1, False, True
            r0 = first_not_below(d, lo, hi, w0) if sliced else lo
            r1 = first_above(d, r0, hi, w1) if sliced else hi
            for i in range(r0, r1):
                if d[i] >= w0 and d[i] <= w1:
                    empty = False
                    if shift != 0.0:
                        frac = (lateral[i] - y_from) / shift
                        if i10 < 0 and frac >= 0.1:
                            i10 = i
                        if i90 < 0 and frac >= 0.9:
                            i90 = i
                        if abs(lateral[i] - y_to) < near:
                            reached = True
            fits[j, k, 0], fits[j, k, 1] = math.nan, 1.0 if sign_from[k] == sign_to[k] else 0.0
            f_start[k] = math.nan
            if shift == 0.0 or empty:
                continue
            fits[j, k, 1] = 1.0 if reached else 0.0
            if i10 < 0 or i90 < 0:
                continue
            length = (d[i90] - d[i10]) / 0.8
            length = 1e-6 if length < 1e-6 else length
            start = d[i10] - 0.1 * length
            f_start[k], f_len[k] = start, length
            fits[j, k, 0] = start - w0
            n_fit += 1
        if hi - lo <= 1:
            out[j, :] = math.nan
            continue
        _normative(d, lo, hi, sign_d, sign_from, sign_to, p, lane_lat, initial_lane, start_before, per_lane, 0.0, yb)
        out[j, 0] = _mean_deviation(d, lateral, yb, lo, hi, buf)
        a_start, a_len, a_off = start_before, per_lane, 0.0  # `fit_adapted_model` (no fit: the basic model)
        if n_fit:
            m = 0
            for k in range(p):
                if math.isfinite(f_start[k]):
                    buf[m] = sign_d[k] - f_start[k]
                    m += 1
            a_start = np.median(buf[:m])
            m = 0
            for k in range(p):
                if math.isfinite(f_start[k]):
                    lanes = abs(sign_to[k] - sign_from[k])
                    buf[m] = f_len[k] / (lanes if lanes > 1 else 1)
                    m += 1
            a_len = np.median(buf[:m])
            _normative(d, lo, hi, sign_d, sign_from, sign_to, p, lane_lat, sign_from[0], a_start, a_len, 0.0, yb)
            for i in range(lo, hi):
                keeping[i] = True
            for k in range(p):
                if math.isfinite(f_start[k]):
                    r0 = first_not_below(d, lo, hi, f_start[k]) if sliced else lo
                    r1 = first_above(d, r0, hi, f_start[k] + f_len[k]) if sliced else hi
                    for i in range(r0, r1):
                        if d[i] >= f_start[k] and d[i] <= f_start[k] + f_len[k]:
                            keeping[i] = False
            m = 0
            for i in range(lo, hi):
                if keeping[i]:
                    buf[m] = lateral[i] - yb[i]
                    m += 1
            a_off = np.median(buf[:m]) if m else 0.0
        _normative(d, lo, hi, sign_d, sign_from, sign_to, p, lane_lat, initial_lane, a_start, a_len, a_off, yb)
        out[j, 1] = _mean_deviation(d, lateral, yb, lo, hi, buf)
        out[j, 2], out[j, 3], out[j, 4] = a_start, a_len, a_off
