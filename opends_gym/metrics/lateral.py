"""Lateral control: standard deviation of lane position (SDLP) and lane exceedances.

Why: SDLP is the most used lane-keeping measure in distraction and impairment research
(Verster et al. 2011; SAE J2944). It depends on segment length and must exclude lane
changes, so the caller passes a mask of the lane-keeping samples.
"""

from __future__ import annotations

import math

import numpy as np


def sdlp(lateral_m: np.ndarray, keep: np.ndarray | None = None, min_valid_fraction: float = 0.0) -> float:
    """Population standard deviation of lateral position over the `keep` samples (m).

    Returns NaN when fewer than two samples remain or less than `min_valid_fraction` of
    the samples are valid (the DWM project required 85 %).
    """
    y = np.asarray(lateral_m, dtype=float)
    mask = np.isfinite(y) if keep is None else (np.asarray(keep, dtype=bool) & np.isfinite(y))
    n = int(mask.sum())
    if n < 2 or (len(y) and n / len(y) < min_valid_fraction):
        return math.nan
    v = y[mask]
    return float(np.sqrt(np.mean((v - v.mean()) ** 2)))


def lane_exceedances(lateral_m: np.ndarray, half_lane_m: float, half_car_m: float = 0.9) -> int:
    """Number of times the car's edge left its lane (entering an exceedance counts once)."""
    y = np.abs(np.asarray(lateral_m, dtype=float))
    out = y + half_car_m > half_lane_m
    return int(np.sum(out[1:] & ~out[:-1]) + (1 if len(out) and out[0] else 0))


def lane_keeping_mask(t_s: np.ndarray, lane_index: np.ndarray, window_s: float = 2.5) -> np.ndarray:
    """True for samples farther than `window_s` from any change of lane index (or off-lane).

    With the changes in time order (a trace's clock), each sample is compared with the two
    changes nearest it only: |t - tc| is smallest at one of them (rounding keeps t - tc
    monotonic in tc), so the result is that of comparing it with every change."""
    t = np.asarray(t_s, dtype=float)
    lane = np.asarray(lane_index, dtype=float)
    keep = lane >= 0
    changes = t[1:][lane[1:] != lane[:-1]]
    if len(changes) == 0:
        return keep
    if len(changes) <= 8 or np.any(changes[1:] < changes[:-1]) or np.isnan(changes).any():  # (few changes: one pass each is cheaper)
        for tc in changes:
            keep &= np.abs(t - tc) > window_s
        return keep
    after = np.searchsorted(changes, t)  # the first change at or after each sample
    above = changes[np.minimum(after, len(changes) - 1)]
    below = changes[np.maximum(after - 1, 0)]
    return keep & (np.abs(t - above) > window_s) & (np.abs(t - below) > window_s)
