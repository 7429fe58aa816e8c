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
