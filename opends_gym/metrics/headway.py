"""Car-following measures: time headway (front to front), time gap and time to collision.

Why: headway flags potential danger, TTC actual conflicts (Vogel 2003). Vogel defines
headway front-to-front: the time between the lead's and the follower's fronts passing
the same point = (gap + lead length) / follower speed. The bumper-to-bumper variant,
gap / follower speed, is the *time gap*. We compute both; `headway_s` in env info is the
front-to-front headway.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .sums import np_sum


def time_headway(gap_m: float, lead_length_m: float, follower_speed_mps: float) -> float:
    """Front-to-front headway (s); inf when the follower stands still or there is no lead."""
    if not math.isfinite(gap_m) or follower_speed_mps <= 0.0:
        return math.inf
    return (gap_m + lead_length_m) / follower_speed_mps


def time_gap(gap_m: float, follower_speed_mps: float) -> float:
    """Bumper-to-bumper time gap (s)."""
    if not math.isfinite(gap_m) or follower_speed_mps <= 0.0:
        return math.inf
    return gap_m / follower_speed_mps


def time_to_collision(gap_m: float, follower_speed_mps: float, lead_speed_mps: float) -> float:
    """gap / closing speed when closing in, else inf (s)."""
    closing = follower_speed_mps - lead_speed_mps
    if not math.isfinite(gap_m) or closing <= 0.0:
        return math.inf
    return max(gap_m, 0.0) / closing


def headway_summary(headway_s: np.ndarray, threshold_s: float = 1.0) -> dict[str, float]:
    """Mean, minimum and share of time below `threshold_s` over samples with a lead."""
    h = np.asarray(headway_s, dtype=float)
    h = h[np.isfinite(h)]
    if len(h) == 0:
        return {"mean_s": math.nan, "min_s": math.nan, "fraction_below": math.nan}
    return {"mean_s": float(h.mean()), "min_s": float(h.min()), "fraction_below": float(np.mean(h < threshold_s))}


def ttc_summary(ttc_s: np.ndarray, dt_s: float, threshold_s: float = 3.0) -> dict[str, float]:
    """Minimum TTC and the time exposed (s) and time integrated (s^2) below `threshold_s`."""
    t = np.asarray(ttc_s, dtype=float)
    finite = t[np.isfinite(t)]
    below = t[np.isfinite(t) & (t < threshold_s)]
    return {
        "min_s": float(finite.min()) if len(finite) else math.inf,
        "time_exposed_s": float(len(below) * dt_s),
        "time_integrated_s2": float(np.sum(threshold_s - below) * dt_s),
    }


# Thresholds reported by `car_following_summary`: THW < 1 s is the common "risky" line and
# 2 s the "two-second rule" (Vogel 2003 discusses both); TTC* between 1.5 and 3 s is used
# for conflicts (Vogel 2003; state it per study). Our defaults, all arguments.
THW_THRESHOLDS_S = (1.0, 2.0)
TTC_THRESHOLDS_S = (1.5, 3.0)


def car_following_summary(
    gap_m: np.ndarray,
    follower_speed_mps: np.ndarray,
    lead_speed_mps: np.ndarray,
    thw_thresholds_s: tuple[float, ...] = THW_THRESHOLDS_S,
    ttc_thresholds_s: tuple[float, ...] = TTC_THRESHOLDS_S,
) -> dict[str, float]:
    """Time headway and time to collision from both vehicles' speeds, per sample.

    THW = gap / v_follower (bumper to bumper, SAE J2944's time gap) over samples with a
    lead (finite gap) and a moving follower; TTC = gap / (v_follower - v_lead) while
    closing in, else inf (Vogel 2003). Shares are of the samples with a lead (equal time
    steps): `thw_below_1s_share` is the share of those with THW < 1 s; `ttc_below_3s_share`
    the share with TTC < 3 s. NaN shares and means when no sample has a lead."""
    gap = np.ascontiguousarray(gap_m, dtype=float)
    vf = np.ascontiguousarray(follower_speed_mps, dtype=float)
    vl = np.ascontiguousarray(lead_speed_mps, dtype=float)
    thw_th = np.array(thw_thresholds_s, dtype=float)
    ttc_th = np.array(ttc_thresholds_s, dtype=float)
    values = np.empty(4 + len(thw_th) + len(ttc_th))
    _car_following(gap, vf, vl, thw_th, ttc_th, values)
    keys = ["lead_share", "thw_mean_s", "thw_min_s", "ttc_min_s"]
    keys += [f"thw_below_{th:g}s_share" for th in thw_thresholds_s] + [f"ttc_below_{th:g}s_share" for th in ttc_thresholds_s]
    return {k: math.nan if v != v else v for k, v in zip(keys, values.tolist())}  # (math.nan itself: equal dicts compare equal)


@kernel
def _car_following(gap: np.ndarray, vf: np.ndarray, vl: np.ndarray, thw_th: np.ndarray, ttc_th: np.ndarray, out: np.ndarray) -> None:
    """`car_following_summary`'s values in one pass, the floats its numpy expressions give:
    THW = max(gap, 0) / v_f and TTC = max(gap, 0) / (v_f - v_l) as `np.maximum` and `/`
    compute them, the mean as `np.mean` sums (`np_sum`), shares as counts / samples."""
    m = len(gap)
    kept = np.empty(m)
    n, nk = 0, 0
    thw_min, ttc_min = math.inf, math.inf
    thw_below = np.zeros(len(thw_th), dtype=np.int64)
    ttc_below = np.zeros(len(ttc_th), dtype=np.int64)
    for i in range(m):
        lead = math.isfinite(gap[i]) and math.isfinite(vl[i])
        if not lead:
            continue
        n += 1
        g = gap[i] if gap[i] >= 0.0 else 0.0  # np.maximum(gap, 0.0) of a finite gap
        h = g / vf[i] if vf[i] > 0.0 else math.inf
        closing = vf[i] - vl[i]
        t = g / closing if closing > 0.0 else math.inf
        if math.isfinite(h):
            kept[nk] = h
            nk += 1
            thw_min = min(thw_min, h)
        if math.isfinite(t):
            ttc_min = min(ttc_min, t)
        for j in range(len(thw_th)):
            if h < thw_th[j]:
                thw_below[j] += 1
        for j in range(len(ttc_th)):
            if t < ttc_th[j]:
                ttc_below[j] += 1
    out[0] = n / m if m else math.nan
    out[1] = np_sum(kept, 0, nk) / nk if nk else math.nan
    out[2] = thw_min if nk else math.nan
    out[3] = ttc_min
    for j in range(len(thw_th)):
        out[4 + j] = thw_below[j] / n if n else math.nan
    for j in range(len(ttc_th)):
        out[4 + len(thw_th) + j] = ttc_below[j] / n if n else math.nan
