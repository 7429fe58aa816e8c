"""Lane Change Test (ISO 26022-style) metrics: mean deviation (MDEV) from a normative path.

Why: the LCT scores a drive by the area between the driven lateral position and a
normative lane-change path, per metre driven. Two normative paths exist:

* **basic** -- the same path for everyone: lane keeping on the lane centre, and at each
  sign a straight (constant-gradient) lane change that starts `start_before_sign_m`
  before the sign and covers one lane width every `length_per_lane_m` (a change over two
  lanes takes twice as long, at the same gradient);
* **adapted** -- fitted per driver from their own lane changes (median start point and
  gradient) and their habitual offset within the lane, so a consistent personal style is
  not scored as error (Tattegrain, Bruyas & Karmann, "Comparison between adaptive and
  basic model metrics in LCT").

Inputs are arrays over the drive: `d` distance along the track (m, increasing) and `y`
lateral position (m) in the same coordinate as `lane_centers_m`. Signs name the lane
index to drive in from that sign on. The default geometry lives with the env
(`opends_gym.envs.lct`); these functions take every parameter explicitly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..jit import inline, kernel


@dataclass(frozen=True)
class LctSign:
    """A lane-change sign at distance `d_m` telling the driver to go to lane `to_lane`."""

    d_m: float
    from_lane: int
    to_lane: int


@dataclass(frozen=True)
class NormativeModel:
    """Where lane changes start (m before the sign), their gradient (m per lane), lane offset."""

    start_before_sign_m: float
    length_per_lane_m: float
    habitual_offset_m: float = 0.0


def normative_path(
    d: np.ndarray, signs: Sequence[LctSign], lane_centers_m: Sequence[float], initial_lane: int, model: NormativeModel
) -> np.ndarray:
    """Normative lateral position at each distance `d` (piecewise linear).

    The latest sign whose lane change has started governs each point: its ramp from the old
    lane to the new (constant gradient, clipped to 0..1), or before any, the initial lane.
    Each point is looked up once (a compiled sorted search), not once per sign."""
    d = np.asarray(d, dtype=float)
    ordered = sorted(signs, key=lambda s: s.d_m)
    start = np.array([s.d_m - model.start_before_sign_m for s in ordered])
    length = np.array([max(model.length_per_lane_m * abs(s.to_lane - s.from_lane), 1e-6) for s in ordered])
    end = start + length
    y_from = np.array([float(lane_centers_m[s.from_lane]) for s in ordered])
    y_to = np.array([float(lane_centers_m[s.to_lane]) for s in ordered])
    y = np.full(d.shape, float(lane_centers_m[initial_lane]))
    if not ordered:
        return y + model.habitual_offset_m
    if np.any(np.diff(start) < 0.0):  # (lane changes that start out of order: each sign in turn)
        for k in range(len(ordered)):
            ramp = np.clip((d - start[k]) / (end[k] - start[k]), 0.0, 1.0)
            y = np.where(d >= start[k], y_from[k] + ramp * (y_to[k] - y_from[k]), y)
        return y + model.habitual_offset_m
    _ramps(d, start, end, y_from, y_to, y)
    return y + model.habitual_offset_m


@kernel
def _ramps(d: np.ndarray, start: np.ndarray, end: np.ndarray, y_from: np.ndarray, y_to: np.ndarray, y: np.ndarray) -> None:
    """`normative_path` for starts in order: at each d the last lane change started there
    (a binary search) sets y on its ramp, clipped to 0..1; before the first (or NaN) y stays."""
    for i in range(len(d)):
        di = d[i]
        k = first_above(start, 0, len(start), di) - 1  # (the number of starts <= di: np.searchsorted, side 'right')
        if k < 0 or math.isnan(di):
            continue
        ramp = (di - start[k]) / (end[k] - start[k])
        ramp = 0.0 if ramp < 0.0 else 1.0 if ramp > 1.0 else ramp
        y[i] = y_from[k] + ramp * (y_to[k] - y_from[k])


@inline
def first_not_below(d: np.ndarray, lo: int, hi: int, v: float) -> int:
    """In a d[lo:hi] that never decreases, the first row i with not d[i] < v (hi: none), by
    bisection: every row at or after it has d >= v (v NaN: lo, and no row has d >= v)."""
    while lo < hi:
        mid = (lo + hi) // 2
        if d[mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return lo


@inline
def first_above(d: np.ndarray, lo: int, hi: int, v: float) -> int:
    """In a d[lo:hi] that never decreases, the first row i with not d[i] <= v (hi: none), by
    bisection: every row before it has d <= v."""
    while lo < hi:
        mid = (lo + hi) // 2
        if d[mid] <= v:
            lo = mid + 1
        else:
            hi = mid
    return lo


def mean_deviation(d: np.ndarray, y: np.ndarray, y_norm: np.ndarray) -> float:
    """Area between the driven and normative lateral paths divided by distance (m)."""
    d = np.asarray(d, dtype=float)
    if len(d) < 2 or d[-1] <= d[0]:
        return math.nan
    diff = np.abs(np.asarray(y, dtype=float) - np.asarray(y_norm, dtype=float))
    area = float(np.sum(0.5 * (diff[1:] + diff[:-1]) * np.diff(d)))
    return area / float(d[-1] - d[0])


@dataclass(frozen=True)
class LaneChangeFit:
    """One lane change as seen in a drive: where it started and how long it took."""

    sign: LctSign
    start_d_m: float  # NaN if the driver never left the old lane
    length_m: float  # over the whole change (all lanes crossed)
    reached_target: bool
    latency_m: float  # start relative to the sign becoming visible


def fit_lane_changes(
    d: np.ndarray, y: np.ndarray, signs: Sequence[LctSign], lane_centers_m: Sequence[float], visibility_m: float
) -> list[LaneChangeFit]:
    """Per sign: the 10 %-90 % ramp of the driver's move, extrapolated to 0 and 100 %."""
    d = np.asarray(d, dtype=float)
    y = np.asarray(y, dtype=float)
    ordered = sorted(signs, key=lambda s: s.d_m)
    out: list[LaneChangeFit] = []
    starts = [sign.d_m - visibility_m for sign in ordered]
    ends = [*starts[1:], d[-1] if len(d) else (ordered[-1].d_m if ordered else 0.0)]
    monotonic = _never_decreases(d)  # (the usual drive): each window is a slice, found by a sorted search
    if monotonic:
        first, stop = np.searchsorted(d, starts, side="left"), np.searchsorted(d, ends, side="right")
    for k, sign in enumerate(ordered):
        y_from = float(lane_centers_m[sign.from_lane])
        y_to = float(lane_centers_m[sign.to_lane])
        shift = y_to - y_from
        window_start, window_end = starts[k], ends[k]
        window: slice | np.ndarray
        if monotonic:
            lo, hi = int(first[k]), int(stop[k])
            window = slice(lo, max(lo, hi))
            empty = hi <= lo
        else:
            mask = (d >= window_start) & (d <= window_end)
            window, empty = mask, not np.any(mask)
        if shift == 0.0 or empty:
            out.append(LaneChangeFit(sign, math.nan, math.nan, sign.from_lane == sign.to_lane, math.nan))
            continue
        dd, y_in = d[window], y[window]
        i10, i90, reached = _ramp_points(y_in, y_from, y_to, shift, 0.5 * abs(shift) * 0.5)
        if i10 < 0 or i90 < 0:
            out.append(LaneChangeFit(sign, math.nan, math.nan, reached, math.nan))
            continue
        d10, d90 = float(dd[i10]), float(dd[i90])
        length = max((d90 - d10) / 0.8, 1e-6)
        start = d10 - 0.1 * length
        out.append(LaneChangeFit(sign, start, length, reached, start - window_start))
    return out


def _never_decreases(d: np.ndarray) -> bool:
    return len(d) < 2 or bool(np.all(d[1:] >= d[:-1]))


@kernel
def _ramp_points(y: np.ndarray, y_from: float, y_to: float, shift: float, near_m: float) -> tuple[int, int, bool]:
    """In one window of a lane change: the first samples 10 % and 90 % of the way from the
    old lane to the new (-1: none) and whether any came within `near_m` of the new lane."""
    i10 = i90 = -1
    reached = False
    for i in range(len(y)):
        frac = (y[i] - y_from) / shift
        if i10 < 0 and frac >= 0.1:
            i10 = i
        if i90 < 0 and frac >= 0.9:
            i90 = i
        if abs(y[i] - y_to) < near_m:
            reached = True
    return i10, i90, reached


def fit_adapted_model(
    d: np.ndarray,
    y: np.ndarray,
    signs: Sequence[LctSign],
    lane_centers_m: Sequence[float],
    visibility_m: float,
    fallback: NormativeModel,
    fits: Sequence[LaneChangeFit] | None = None,
) -> NormativeModel:
    """A driver's own normative model: median start and length, median in-lane offset.
    `fits`: `fit_lane_changes` of the same inputs, when the caller has them already."""
    d = np.asarray(d, dtype=float)
    if fits is None:
        fits = fit_lane_changes(d, y, signs, lane_centers_m, visibility_m)
    fits = [f for f in fits if math.isfinite(f.start_d_m)]
    if not fits:
        return fallback
    start_before = float(np.median([f.sign.d_m - f.start_d_m for f in fits]))
    per_lane = float(np.median([f.length_m / max(1, abs(f.sign.to_lane - f.sign.from_lane)) for f in fits]))
    basic = normative_path(d, signs, lane_centers_m, signs[0].from_lane if signs else 0, NormativeModel(start_before, per_lane))
    keeping = np.ones(len(d), dtype=bool)
    lows = [f.start_d_m for f in fits]
    highs = [f.start_d_m + f.length_m for f in fits]
    if _never_decreases(d):  # each change's samples are a slice
        for a, b in zip(np.searchsorted(d, lows, side="left"), np.searchsorted(d, highs, side="right"), strict=True):
            keeping[a:b] = False
    else:
        for lo, hi in zip(lows, highs, strict=True):
            keeping &= ~((d >= lo) & (d <= hi))
    offset = float(np.median(np.asarray(y)[keeping] - basic[keeping])) if np.any(keeping) else 0.0
    return NormativeModel(start_before, per_lane, offset)


def lct_mdev(
    d: np.ndarray,
    y: np.ndarray,
    signs: Sequence[LctSign],
    lane_centers_m: Sequence[float],
    initial_lane: int,
    basic: NormativeModel,
    visibility_m: float,
    fits: Sequence[LaneChangeFit] | None = None,
) -> dict[str, float]:
    """MDEV against the basic and the adapted model, plus the fitted adapted parameters
    (`fits`: `fit_lane_changes` of the same inputs, when the caller has them already)."""
    y_basic = normative_path(d, signs, lane_centers_m, initial_lane, basic)
    adapted = fit_adapted_model(d, y, signs, lane_centers_m, visibility_m, basic, fits)
    y_adapted = normative_path(d, signs, lane_centers_m, initial_lane, adapted)
    return {
        "mdev_basic_m": mean_deviation(d, y, y_basic),
        "mdev_adapted_m": mean_deviation(d, y, y_adapted),
        "adapted_start_before_sign_m": adapted.start_before_sign_m,
        "adapted_length_per_lane_m": adapted.length_per_lane_m,
        "adapted_habitual_offset_m": adapted.habitual_offset_m,
    }
