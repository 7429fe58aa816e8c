"""Lateral control: standard deviation of lane position (SDLP) and lane exceedances.

Why: SDLP is the most used lane-keeping measure in distraction and impairment research
(Verster et al. 2011; SAE J2944). It depends on segment length and must exclude lane
changes, so the caller passes a mask of the lane-keeping samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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


# SDLP over fixed segments (SAE J2944): our defaults. The 85 % minimum valid fraction is
# the Driver Workload Metrics project's rule (Angell et al. 2006); the 30 s segment length
# is our choice (J2944 asks that the segment length be fixed and reported with the value;
# its text was not available to us, so no length is quoted from it).
SDLP_SEGMENT_S = 30.0
SDLP_MIN_VALID_FRACTION = 0.85


@dataclass(frozen=True)
class SdlpSegment:
    start: float  # in the unit of the segmenting axis (s or m)
    end: float
    sdlp_m: float  # NaN when the valid fraction is below the minimum
    valid_fraction: float  # valid samples / samples not excluded (NaN: all excluded)


@dataclass(frozen=True)
class SdlpResult:
    """SDLP per SAE J2944: the mean of the per-segment SDLPs of the segments with enough
    valid samples (NaN when none has), with every segment and the valid fractions."""

    sdlp_m: float
    valid_fraction: float  # valid / not excluded, over all samples
    excluded_fraction: float  # samples inside instructed lane changes
    segments: tuple[SdlpSegment, ...]
    segment_length: float

    @property
    def segments_valid(self) -> int:
        return sum(1 for s in self.segments if math.isfinite(s.sdlp_m))


def sdlp_segments(
    axis: np.ndarray,
    lateral_m: np.ndarray,
    exclude: np.ndarray | None = None,
    valid: np.ndarray | None = None,
    segment_length: float = SDLP_SEGMENT_S,
    min_valid_fraction: float = SDLP_MIN_VALID_FRACTION,
) -> SdlpResult:
    """SDLP over consecutive fixed-length segments of `axis` (time in s or distance in m,
    increasing); a last partial segment shorter than the rest is dropped.

    `exclude` marks the samples of instructed lane changes: they are left out and do not
    count against the segment. Of the rest, `valid` (default: finite lateral position)
    marks usable data; a segment whose valid share is below `min_valid_fraction` has NaN
    SDLP, its fraction reported either way. Per segment the population SD of the valid
    samples; the result is the mean over the segments with a value."""
    if segment_length <= 0.0:
        raise ValueError(f"segment_length must be > 0, got {segment_length}")
    a = np.asarray(axis, dtype=float)
    y = np.asarray(lateral_m, dtype=float)
    counted = np.ones(len(y), dtype=bool) if exclude is None else ~np.asarray(exclude, dtype=bool)
    ok = np.isfinite(y) if valid is None else (np.asarray(valid, dtype=bool) & np.isfinite(y))
    ok &= counted
    segments: list[SdlpSegment] = []
    if len(a) >= 2:
        n_seg = int((a[-1] - a[0]) // segment_length)
        bounds = a[0] + segment_length * np.arange(n_seg + 1)
        idx = np.searchsorted(a, bounds, side="left")
        for k in range(n_seg):
            lo, hi = int(idx[k]), int(idx[k + 1])
            n = int(counted[lo:hi].sum())
            frac = float(ok[lo:hi].sum()) / n if n else math.nan
            value = sdlp(y[lo:hi], ok[lo:hi]) if n and frac >= min_valid_fraction else math.nan
            segments.append(SdlpSegment(float(bounds[k]), float(bounds[k + 1]), value, frac))
    finite = [s.sdlp_m for s in segments if math.isfinite(s.sdlp_m)]
    n_counted = int(counted.sum())
    return SdlpResult(
        sdlp_m=float(np.mean(finite)) if finite else math.nan,
        valid_fraction=float(ok.sum()) / n_counted if n_counted else math.nan,
        excluded_fraction=1.0 - n_counted / len(y) if len(y) else math.nan,
        segments=tuple(segments),
        segment_length=segment_length,
    )
