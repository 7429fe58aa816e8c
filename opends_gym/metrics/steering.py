"""Steering wheel reversal rate (SRR), following Markkula & Engstroem (2006).

Why: small steering reversals rise with cognitive load, larger ones with visual load.
The algorithm (as in the reference MATLAB `metric_ReversalRate_VTEC.m`): low-pass the
steering angle with a 2nd-order Butterworth filter run forwards and backwards (zero
phase), find its stationary points, and count movements between consecutive extrema in
opposite directions whose amplitude is at least the gap size. The rate is reversals per
minute. Report the gap and cut-off with every value.

The filter is designed here (bilinear transform) and run by a small compiled loop (scipy's
`signal` module would cost over a second to import at the first episode's end).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..jit import inline, kernel


def butter2_lowpass(cutoff_hz: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients (b, a) of a 2nd-order Butterworth low-pass (bilinear, pre-warped)."""
    b, a = _butter2(float(cutoff_hz), float(fs_hz))
    return b.copy(), a.copy()


@functools.lru_cache(maxsize=64)
def _butter2(cutoff_hz: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(every episode end asks for the same few filters)"""
    if not 0 < cutoff_hz < fs_hz / 2:
        raise ValueError("cutoff must be between 0 and the Nyquist frequency")
    k = math.tan(math.pi * cutoff_hz / fs_hz)
    q = math.sqrt(2.0)
    norm = 1.0 / (1.0 + q * k + k * k)
    b = np.array([k * k * norm, 2.0 * k * k * norm, k * k * norm])
    a = np.array([1.0, 2.0 * (k * k - 1.0) * norm, (1.0 - q * k + k * k) * norm])
    return b, a


@kernel
def _lfilter(b: np.ndarray, a: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """A 2nd-order IIR filter (direct form II transposed) from the initial state zi."""
    y = np.empty_like(x)
    z0, z1 = zi[0], zi[1]
    b0, b1, b2 = b[0], b[1], b[2]
    a1, a2 = a[1], a[2]
    for i in range(len(x)):
        xi = x[i]
        yi = b0 * xi + z0
        z0 = b1 * xi - a1 * yi + z1
        z1 = b2 * xi - a2 * yi
        y[i] = yi
    return y


def _steady_state(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Initial filter state for a unit step (as scipy's lfilter_zi)."""
    return _steady_state_of(tuple(b.tolist()), tuple(a.tolist()))


@functools.lru_cache(maxsize=64)
def _steady_state_of(b: tuple[float, ...], a: tuple[float, ...]) -> np.ndarray:
    m = np.array([[1.0 + a[1], -1.0], [a[2], 1.0]])
    rhs = np.array([b[1] - a[1] * b[0], b[2] - a[2] * b[0]])
    out = np.linalg.solve(m, rhs)
    out.flags.writeable = False  # (shared by every call with these coefficients)
    return out


def filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Zero-phase filtering with odd-extension padding (like scipy.signal.filtfilt)."""
    x = np.ascontiguousarray(x, dtype=float)
    return _zero_phase(b, a, _steady_state(b, a), x)


@kernel
def _zero_phase(b: np.ndarray, a: np.ndarray, zi: np.ndarray, x: np.ndarray) -> np.ndarray:
    """`filtfilt` of a 2nd-order filter with steady state zi: x padded by its odd extension
    (9 samples, fewer for short x) at both ends, filtered forwards from zi * the first
    padded sample, backwards from zi * the last output, unpadded. (A kernel: native batch
    scoring calls it from compiled code.)"""
    n = len(x)
    pad = min(3 * max(len(a), len(b)), n - 1)
    if pad < 1:
        return x.copy()
    ext = np.empty(n + 2 * pad)
    for k in range(pad):
        ext[k] = 2.0 * x[0] - x[pad - k]
        ext[pad + n + k] = 2.0 * x[n - 1] - x[n - 2 - k]
    ext[pad : pad + n] = x
    z = np.empty(2)
    z[0], z[1] = zi[0] * ext[0], zi[1] * ext[0]
    y = _lfilter(b, a, ext, z)
    z[0], z[1] = zi[0] * y[len(y) - 1], zi[1] * y[len(y) - 1]
    back = _lfilter(b, a, np.ascontiguousarray(y[::-1]), z)
    out = np.empty(n)
    for i in range(n):
        out[i] = back[len(back) - 1 - pad - i]
    return out


def reversal_count(angle_deg: np.ndarray, gap_deg: float) -> int:
    """Reversals of at least `gap_deg` between the stationary points of a (filtered) signal."""
    x = np.ascontiguousarray(angle_deg, dtype=float)
    if len(x) < 3:
        return 0
    return int(_reversal_count(x, float(gap_deg)))


@kernel
def _reversal_count(x: np.ndarray, gap_deg: float) -> int:
    values = np.empty(len(x))
    return _count_reversals(values, _stationary_points(x, values), gap_deg)


@kernel
def reversal_counts(x: np.ndarray, gaps_deg: np.ndarray, counts: np.ndarray) -> None:
    """counts[g] += the reversals of at least gaps_deg[g] of a (filtered) signal of 3 samples
    or more: `_reversal_count` at every gap, the stationary points found once for all."""
    if len(x) < 3:
        return
    values = np.empty(len(x))
    m = _stationary_points(x, values)
    for g in range(len(gaps_deg)):
        counts[g] += _count_reversals(values, m, gaps_deg[g])


@inline
def _stationary_points(x: np.ndarray, values: np.ndarray) -> int:
    """The stationary points of x (sign changes of the derivative, plateaus taking their
    first sample), with its first and last sample, into values[:m]; m = 0 when x is flat."""
    values[0] = x[0]
    m, prev, seen = 1, 0.0, False
    for i in range(len(x) - 1):
        d = x[i + 1] - x[i]
        if d == 0.0:
            continue
        sign = 1.0 if d > 0.0 else -1.0 if d < 0.0 else math.nan
        if seen and sign != prev:
            values[m] = x[i]
            m += 1
        prev, seen = sign, True
    if not seen:
        return 0
    values[m] = x[len(x) - 1]
    return m + 1


@inline
def _count_reversals(values: np.ndarray, m: int, gap_deg: float) -> int:
    """Reversals of at least `gap_deg` among the m stationary points in values."""
    count = 0
    # count upward and downward reversals separately, as the reference implementation
    for direction in (1.0, -1.0):
        anchor = values[0]
        for k in range(1, m):
            v = values[k]
            if direction * (v - anchor) >= gap_deg:
                count += 1
                anchor = v
            elif direction * (v - anchor) < 0:
                anchor = v
    return count


def reversal_rate(angle_deg: np.ndarray, fs_hz: float, gap_deg: float = 2.0, cutoff_hz: float = 0.6) -> float:
    """Steering reversals per minute of a steering-wheel angle trace sampled at `fs_hz`."""
    x = np.asarray(angle_deg, dtype=float)
    if len(x) < 3:
        return math.nan
    duration_min = (len(x) - 1) / fs_hz / 60.0
    filtered = filtfilt(*butter2_lowpass(cutoff_hz, fs_hz), x) if cutoff_hz < fs_hz / 2 else x
    return reversal_count(filtered, gap_deg) / duration_min if duration_min > 0 else math.nan


# The gaps reported by `reversal_rates`: 0.5 deg (small corrections, sensitive to
# cognitive load), 2 deg (Östlund et al. 2005, HASTE deliverable 2, and Markkula &
# Engström 2006: sensitive to visual load) and 10 deg (large corrections). Reversal
# counting goes back to Macdonald & Hoffmann 1980 (Human Factors 22(6)).
SRR_GAPS_DEG = (0.5, 2.0, 10.0)
SRR_MIN_SEGMENT_S = 5.0  # shorter lane-keeping stretches are too short to filter (our choice)


def reversal_rates(
    angle_deg: np.ndarray,
    fs_hz: float,
    keep: np.ndarray | None = None,
    gaps_deg: tuple[float, ...] = SRR_GAPS_DEG,
    cutoff_hz: float = 0.6,
    min_segment_s: float = SRR_MIN_SEGMENT_S,
) -> dict[float, float]:
    """Reversals per minute at each gap over the lane-keeping segments only: each run of
    `keep` samples at least `min_segment_s` long is filtered and counted on its own (a lane
    change's steering is no reversal), and the counts are divided by their total duration.
    NaN for every gap when no segment is long enough."""
    x = np.asarray(angle_deg, dtype=float)
    mask = np.ones(len(x), dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    min_n = max(3, int(math.ceil(min_segment_s * fs_hz)) + 1)
    counts = dict.fromkeys(gaps_deg, 0)
    duration_s = 0.0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    for lo, hi in zip(edges[::2], edges[1::2], strict=True):
        if hi - lo < min_n:
            continue
        seg = x[lo:hi]
        filtered = filtfilt(*butter2_lowpass(cutoff_hz, fs_hz), seg) if cutoff_hz < fs_hz / 2 else seg
        for g in gaps_deg:
            counts[g] += reversal_count(filtered, g)
        duration_s += (hi - lo - 1) / fs_hz
    if duration_s <= 0.0:
        return dict.fromkeys(gaps_deg, math.nan)
    return {g: counts[g] / (duration_s / 60.0) for g in gaps_deg}


def gap_key(gap_deg: float) -> str:
    """`0.5` -> `0_5deg`: the gap as it appears in metric names."""
    return f"{gap_deg:g}".replace(".", "_") + "deg"
