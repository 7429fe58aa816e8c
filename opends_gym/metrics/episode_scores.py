"""The generic episode metrics of many episodes in one compiled pass (native batch scoring).

Why: a native brake or platoon batch under random actions ends ~130 episodes per 1,000
env-steps; scoring each with `OpenDSEnv.episode_metrics` (SDLP, SAE J2944 segments,
steering reversal rates, car following) cost ~200 µs of Python per episode, more than
stepping it. `episode_scores` computes the trace-based keys of `OpenDSEnv.episode_metrics`
and `_standard_metrics` (`KEYS`) for all the episodes that ended on one step at once, for
tasks without instructed lane changes (SDLP over the road-fixed lateral position, lane
keeping from the lane index). The floats are those of the numpy code: means are numpy's
pairwise sums (`sums.np_sum`) over the same samples, filters run `steering._zero_phase`
(the single env's), and shares are counts over lengths as `np.mean` of a boolean array
computes them. Distances come in as `np.hypot` steps (numba's `math.hypot` is libm's, the
kernel's Python twin CPython's: they differ).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .headway import FOLLOWING, THW_THRESHOLDS_S, TTC_THRESHOLDS_S
from .lateral import SDLP_MIN_VALID_FRACTION, SDLP_SEGMENT_S
from .steering import (
    SRR_GAPS_DEG,
    SRR_MIN_SEGMENT_S,
    _reversal_count,
    _steady_state,
    _zero_phase,
    butter2_lowpass,
    gap_key,
    reversal_counts,
)
from .sums import np_sum

KEYS: tuple[str, ...] = (
    "distance_m",
    "mean_speed_kmh",
    "sdlp_m",
    "steering_reversal_rate_per_min",
    "mean_headway_s",
    "min_ttc_s",
    "mean_abs_lateral_offset_m",
    "off_road_s",
    "road_exits",
    "sdlp_j2944_m",
    "sdlp_j2944_valid_fraction",
    "sdlp_j2944_excluded_fraction",
    "sdlp_j2944_segments",
    "sdlp_j2944_segments_valid",
    *(f"steering_reversal_rate_{gap_key(g)}_per_min" for g in SRR_GAPS_DEG),
    "lead_share",
    "following_share",
    "thw_mean_s",
    "thw_min_s",
    *(f"thw_below_{th:g}s_share".replace(".", "_") for th in THW_THRESHOLDS_S),
    *(f"ttc_below_{th:g}s_share".replace(".", "_") for th in TTC_THRESHOLDS_S),
)
LANE_CHANGE_WINDOW_S = 2.5  # `lateral.lane_keeping_mask`'s default window
SRR_CUTOFF_HZ = 0.6  # `reversal_rate`'s and `reversal_rates`' default low-pass


Params = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def scoring_params(fs_hz: float, off_road_limit_m: float, road_edges_m: tuple[float, float]) -> Params:
    """The constant arguments of `episode_scores` for a task: (filter b, a, steady state,
    floats, gaps, THW thresholds, TTC thresholds). floats: physics rate (Hz), off-road
    limit |lateral| (m, `_off_road_mask`), the road's left and right edges (m), the
    lane-change window (s), the car-following criterion (min speed, max gap, max relative
    speed, min duration - 1e-9), SDLP segment length and minimum valid fraction, the reversal
    rates' minimum segment (samples), 1.0 where the low-pass cut-off is below Nyquist."""
    filtering = fs_hz / 2 > SRR_CUTOFF_HZ  # (`reversal_rate` filters below Nyquist only)
    b, a = butter2_lowpass(SRR_CUTOFF_HZ, fs_hz) if filtering else (np.zeros(3), np.ones(3))
    zi = np.array(_steady_state(b, a)) if filtering else np.zeros(2)
    c = FOLLOWING
    floats = np.array([
        fs_hz, off_road_limit_m, road_edges_m[0], road_edges_m[1], LANE_CHANGE_WINDOW_S, c.min_speed_mps, c.max_gap_m,
        c.max_relative_speed_mps, c.min_duration_s - 1e-9, SDLP_SEGMENT_S, SDLP_MIN_VALID_FRACTION,
        max(3, int(math.ceil(SRR_MIN_SEGMENT_S * fs_hz)) + 1), 1.0 if filtering else 0.0,
    ])  # fmt: skip
    return b, a, zi, floats, np.array(SRR_GAPS_DEG), np.array(THW_THRESHOLDS_S), np.array(TTC_THRESHOLDS_S)


@kernel
def _filtered(b: np.ndarray, a: np.ndarray, zi: np.ndarray, on: bool, x: np.ndarray, lo: int, n: int) -> np.ndarray:
    """x[lo:lo+n] low-passed forwards and backwards (`steering.filtfilt`; `on` False: as is)."""
    seg = np.ascontiguousarray(x[lo : lo + n])
    return _zero_phase(b, a, zi, seg) if on else seg


@kernel
def _reversals(y: np.ndarray, gap: float) -> int:
    """`steering.reversal_count` of a filtered signal."""
    return 0 if len(y) < 3 else _reversal_count(y, gap)


@kernel
def _sdlp(y: np.ndarray, keep: np.ndarray, lo: int, n: int, buf: np.ndarray) -> float:
    """`lateral.sdlp(y[lo:lo+n], keep[lo:lo+n])` (min valid fraction 0)."""
    m = 0
    for i in range(lo, lo + n):
        if keep[i] and math.isfinite(y[i]):
            buf[m] = y[i]
            m += 1
    if m < 2:
        return math.nan
    mean = np_sum(buf, 0, m) / m
    for i in range(m):
        d = buf[i] - mean
        buf[i] = d * d
    return math.sqrt(np_sum(buf, 0, m) / m)


@kernel
def j2944_segments(t: np.ndarray, y: np.ndarray, keep: np.ndarray, lo: int, hi: int, seg_len: float, min_valid: float,
                   segs: np.ndarray, buf: np.ndarray) -> tuple[int, int]:  # fmt: skip
    """(segments, valid segments) of `lateral.sdlp_segments` over y[lo:hi] with keep's samples
    counted; each valid segment's SDLP goes to segs[0:valid] (the episode and LCT scorers share it)."""
    n_seg, valid = 0, 0
    if hi - lo >= 2:
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
                segs[valid] = value
                valid += 1
            i0 = i1
    return n_seg, valid


@kernel
def reversal_rates_into(row: np.ndarray, at: int, keep: np.ndarray, lo: int, hi: int, min_run: int, fs: float, b: np.ndarray,
                        a: np.ndarray, zi: np.ndarray, on: bool, steer_deg: np.ndarray, gaps: np.ndarray) -> None:  # fmt: skip
    """`steering.reversal_rates` over keep's stretches of at least min_run samples, one rate
    per gap into row[at:at+len(gaps)] (the episode and LCT scorers share it)."""
    counts = np.zeros(len(gaps), dtype=np.int64)
    duration = 0.0
    run = -1
    for i in range(lo, hi + 1):
        kk = keep[i] if i < hi else False
        if kk and run < 0:
            run = i
        elif not kk and run >= 0:
            if i - run >= min_run:
                reversal_counts(_filtered(b, a, zi, on, steer_deg, run, i - run), gaps, counts)
                duration += (i - run - 1) / fs
            run = -1
    for g in range(len(gaps)):
        row[at + g] = counts[g] / (duration / 60.0) if duration > 0.0 else math.nan


@kernel
def episode_scores(starts: np.ndarray, t: np.ndarray, ds: np.ndarray, speed: np.ndarray, steer_deg: np.ndarray, gap: np.ndarray,
                   lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray, lateral: np.ndarray, lane: np.ndarray,
                   offset: np.ndarray, b: np.ndarray, a: np.ndarray, zi: np.ndarray, p: np.ndarray, gaps: np.ndarray,
                   thw_th: np.ndarray, ttc_th: np.ndarray, out: np.ndarray, j2944: bool = True, traffic: bool = True) -> None:  # fmt: skip
    """`KEYS` of episodes j = 0..m-1 into out[j]: rows starts[j]..starts[j+1]-1 of the trace
    columns are episode j's trace (reset row first), ds[i] the `np.hypot` step from row i to
    i+1; `p` etc. from `scoring_params`. `j2944` False leaves out[j, 9:14 + len(gaps)] (SAE
    J2944 and the reversal rates) unwritten, for a caller that scores them its own way (the LCT).
    `traffic` False: episodes without a lead car (gap, lead speed, headway and TTC are not
    read): the car-following keys as gaps of inf and lead speeds of NaN give them, without
    their loops over the rows (the LCT's; ~25 % of this kernel's time on its episodes)."""
    fs, limit, left, right, window, min_v, max_gap, max_rel = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    min_dur, seg_len, min_valid, min_run, on = p[8], p[9], p[10], p[11], p[12] > 0.0
    total = len(t)
    keep = np.empty(total, dtype=np.bool_)
    follow = np.empty(total, dtype=np.bool_)
    buf = np.empty(total)
    buf2 = np.empty(total)  # the episode's lane-change times
    segs = np.empty(total)  # its SDLP segments' values
    everywhere = np.ones(total, dtype=np.bool_)
    for j in range(len(starts) - 1):
        lo, hi = starts[j], starts[j + 1]
        n = hi - lo
        row = out[j]
        row[0] = np_sum(ds, lo, n - 1) if n >= 2 else 0.0
        row[1] = np_sum(speed, lo, n) / n * 3.6 if n else math.nan
        # lane keeping (`lateral.lane_keeping_mask`): away from every change of lane index
        changes = 0
        for i in range(lo + 1, hi):
            if lane[i] != lane[i - 1]:
                buf2[changes] = t[i]
                changes += 1
        c = 0
        for i in range(lo, hi):
            k = lane[i] >= 0
            if changes and k:
                while c < changes and buf2[c] < t[i]:
                    c += 1
                if c < changes and not abs(t[i] - buf2[c]) > window:
                    k = False
                if c > 0 and not abs(t[i] - buf2[c - 1]) > window:
                    k = False
            keep[i] = k
        row[2] = _sdlp(offset, keep, lo, n, buf)
        if n > 3:
            y = _filtered(b, a, zi, on, steer_deg, lo, n)
            minutes = (n - 1) / fs / 60.0
            row[3] = _reversals(y, 2.0) / minutes if minutes > 0 else math.nan
        else:
            row[3] = math.nan
        if traffic:
            # car following (`headway.following_mask`)
            run = -1
            for i in range(lo, hi + 1):
                ok = False
                if i < hi:
                    g, vf, vl = gap[i], speed[i], lead_v[i]
                    ok = math.isfinite(g) and math.isfinite(vl) and vf > min_v and g < max_gap and abs(vf - vl) <= max_rel
                if ok and run < 0:
                    run = i
                elif not ok and run >= 0:
                    long = t[i - 1] - t[run] >= min_dur
                    for r in range(run, i):
                        follow[r] = long
                    run = -1
                if i < hi and not ok:
                    follow[i] = False
            m = 0
            for i in range(lo, hi):
                if follow[i]:
                    buf[m] = headway[i]
                    m += 1
            row[4] = np_sum(buf, 0, m) / m if m else math.nan
            low, seen = math.inf, False
            for i in range(lo, hi):
                if math.isfinite(ttc[i]) and (not seen or ttc[i] < low):
                    low, seen = ttc[i], True
            row[5] = low
        else:
            row[4], row[5] = math.nan, math.inf
        for i in range(lo, hi):
            buf[i - lo] = abs(offset[i])
        row[6] = np_sum(buf, 0, n) / n if n else math.nan
        off_count, exits = 0, 0
        for i in range(lo, hi):
            if i > lo and (lateral[i] > left or lateral[i] < right):
                off_count += 1
            off = abs(lateral[i]) > limit
            if off and (i == lo or not abs(lateral[i - 1]) > limit):
                exits += 1
        row[7] = float(off_count) / fs
        row[8] = exits
        if j2944:
            # SDLP over fixed segments (`lateral.sdlp_segments`, nothing excluded, valid: finite)
            ok_all = 0
            for i in range(lo, hi):
                if math.isfinite(lateral[i]):
                    ok_all += 1
            n_seg, valid_segs = j2944_segments(t, lateral, everywhere, lo, hi, seg_len, min_valid, segs, buf)
            row[9] = np_sum(segs, 0, valid_segs) / valid_segs if valid_segs else math.nan
            row[10] = float(ok_all) / n if n else math.nan
            row[11] = 1.0 - n / n if n else math.nan
            row[12] = n_seg
            row[13] = valid_segs
            # steering reversal rates over the lane-keeping stretches (`steering.reversal_rates`)
            reversal_rates_into(row, 14, keep, lo, hi, min_run, fs, b, a, zi, on, steer_deg, gaps)
        base = 14 + len(gaps)
        if traffic:
            # car following summary (`headway.car_following_summary`)
            leads, m, thw_lo = 0, 0, math.nan
            for i in range(lo, hi):
                if math.isfinite(gap[i]) and math.isfinite(lead_v[i]):
                    leads += 1
                if follow[i]:
                    g = gap[i] if (gap[i] >= 0.0 or gap[i] != gap[i]) else 0.0
                    v = g / speed[i]
                    buf[m] = v
                    if m == 0 or not (thw_lo <= v or thw_lo != thw_lo):
                        thw_lo = v
                    m += 1
            row[base] = leads / n if n else math.nan
            row[base + 1] = m / n if n else math.nan
            row[base + 2] = np_sum(buf, 0, m) / m if m else math.nan
            row[base + 3] = thw_lo if m else math.nan
            for k in range(len(thw_th)):
                below = 0
                for i in range(m):
                    if buf[i] < thw_th[k]:
                        below += 1
                row[base + 4 + k] = below / m if m else math.nan
            nt = len(thw_th)
            for k in range(len(ttc_th)):
                below = 0
                for i in range(lo, hi):
                    if math.isfinite(gap[i]) and math.isfinite(lead_v[i]):
                        closing = speed[i] - lead_v[i]
                        g = gap[i] if gap[i] >= 0.0 else 0.0
                        v = g / closing if closing > 0.0 else math.inf
                        if v < ttc_th[k]:
                            below += 1
                row[base + 4 + nt + k] = below / leads if leads else math.nan
        else:  # (no lead car in the episode: what the loops above give for gaps of inf and lead speeds of NaN)
            row[base] = 0.0 if n else math.nan
            row[base + 1] = 0.0 if n else math.nan
            for k in range(2, 4 + len(thw_th) + len(ttc_th)):
                row[base + k] = math.nan
