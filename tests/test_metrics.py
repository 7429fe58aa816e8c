"""Metric functions against hand-computed values."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from opends_gym.metrics import (
    LctSign,
    NormativeModel,
    lct_mdev,
    mean_ci,
    normative_path,
    reversal_rate,
    score_drt,
    sdlp,
    time_gap,
    time_headway,
    time_to_collision,
)
from opends_gym.metrics.lateral import lane_exceedances, lane_keeping_mask
from opends_gym.metrics.lct import mean_deviation as lct_area_mean
from opends_gym.metrics.reaction import brake_reaction_time, summarize_reactions
from opends_gym.metrics.stats import t_quantile
from opends_gym.metrics.steering import butter2_lowpass, filtfilt, reversal_count, reversal_counts


def test_sdlp_and_exceedances() -> None:
    y = np.array([0.1, -0.1, 0.1, -0.1])
    assert sdlp(y) == pytest.approx(0.1)
    keep = np.array([True, True, False, False])
    assert sdlp(np.array([1.0, 3.0, 50.0, 60.0]), keep) == pytest.approx(1.0)
    assert math.isnan(sdlp(np.array([1.0, np.nan, np.nan, np.nan]), min_valid_fraction=0.85))
    assert lane_exceedances(np.array([0.0, 1.0, 0.0, 1.2, 1.3, 0.0]), half_lane_m=1.85, half_car_m=0.9) == 2


def test_headway_gap_ttc() -> None:
    assert time_headway(20.0, 4.0, 12.0) == pytest.approx(2.0)
    assert time_gap(20.0, 10.0) == pytest.approx(2.0)
    assert time_to_collision(30.0, 20.0, 10.0) == pytest.approx(3.0)
    assert time_to_collision(30.0, 10.0, 20.0) == math.inf
    assert time_headway(10.0, 4.0, 0.0) == math.inf


def test_reversal_rate_counts_sine_reversals() -> None:
    fs = 60.0
    t = np.arange(0, 60, 1 / fs)
    big = 5.0 * np.sin(2 * np.pi * 0.25 * t)  # 15 cycles/min, 2 reversals each
    assert reversal_rate(big, fs, gap_deg=2.0, cutoff_hz=0.6) == pytest.approx(30.0, abs=1.5)
    small = 0.4 * np.sin(2 * np.pi * 0.25 * t)  # amplitude 0.8 p-p: below a 2 degree gap
    assert reversal_rate(small, fs, gap_deg=2.0) == 0.0
    assert reversal_count(np.array([0.0, 3.0, 0.5, 3.0, 0.0]), gap_deg=2.0) == 4


def test_reversal_counts_at_several_gaps_are_each_gaps_count() -> None:
    """`reversal_counts` (the native scorers': stationary points found once for every gap)
    adds to each gap's count what `reversal_count` gives at that gap, on filtered random
    walks, plateaus, a flat signal and signals too short to count."""
    gaps = np.array([0.5, 2.0, 10.0])
    rng = np.random.default_rng(4)
    signals = [filtfilt(*butter2_lowpass(0.6, 60.0), np.cumsum(rng.normal(0, 1.0, 3000))) for _ in range(5)]
    signals += [np.round(np.cumsum(rng.normal(0, 1.0, 500))), np.zeros(50), np.array([1.0, 4.0])]
    for x in signals:
        counts = np.full(3, 7, dtype=np.int64)
        reversal_counts(x, gaps, counts)
        assert list(counts) == [7 + reversal_count(x, g) for g in gaps]
    assert sum(reversal_count(x, 0.5) for x in signals) > sum(reversal_count(x, 10.0) for x in signals) > 0


def test_filtfilt_is_zero_phase_and_passes_dc() -> None:
    b, a = butter2_lowpass(0.6, 60.0)
    assert float(np.sum(b) / np.sum(a)) == pytest.approx(1.0)
    t = np.arange(0, 30, 1 / 60)
    slow = np.sin(2 * np.pi * 0.05 * t)
    out = filtfilt(b, a, slow)
    assert np.max(np.abs(out - slow)[300:-300]) < 0.01  # no lag at low frequency


def test_drt_scoring_iso17488_windows() -> None:
    s = score_drt([1.0, 5.0, 9.0, 13.0], [1.05, 5.5, 12.0, 13.3])
    assert (s.hits, s.misses, s.premature) == (2, 2, 1)
    assert s.hit_rate == 0.5 and s.mean_rt_s == pytest.approx(0.4)


def test_brake_reaction_time_interpolates_threshold() -> None:
    t = np.arange(0, 3, 0.1)
    acc = np.where(t < 0.8, 1.0, 0.0)
    brake = np.clip((t - 1.0) * 2.0, 0.0, 1.0)
    r = brake_reaction_time(t, acc, brake, stimulus_s=0.5, brake_threshold=0.1)
    assert r.accelerator_release_s == pytest.approx(0.3)
    assert r.brake_onset_s == pytest.approx(0.55)


def test_reaction_summary_by_group() -> None:
    summary = summarize_reactions([("Brake", 1, 0.8), ("Brake", 1, 1.0), ("Brake", -2, 10.0), ("Lane", -1, 10.0)])
    assert summary["Brake"].correct == 2 and summary["Brake"].misses == 1
    assert summary["Brake"].mean_rt_s == pytest.approx(0.9)
    assert summary["Lane"].failures == 1 and math.isnan(summary["Lane"].mean_rt_s)


def test_lct_normative_path_and_mdev() -> None:
    centers = [-3.5, 0.0, 3.5]
    signs = [LctSign(100.0, 1, 2), LctSign(250.0, 2, 0)]
    model = NormativeModel(start_before_sign_m=30.0, length_per_lane_m=20.0)
    d = np.linspace(0, 400, 4001)
    y = normative_path(d, signs, centers, 1, model)
    assert y[np.searchsorted(d, 50)] == pytest.approx(0.0)
    assert y[np.searchsorted(d, 80)] == pytest.approx(1.75)  # half-way through the first change
    assert y[np.searchsorted(d, 120)] == pytest.approx(3.5)
    assert y[np.searchsorted(d, 230)] == pytest.approx(1.75)  # two lanes: twice the length, same gradient
    assert y[-1] == pytest.approx(-3.5)
    # a driver exactly on the normative path scores zero; one 0.5 m off everywhere 0.5
    assert lct_area_mean(d, y, y) == pytest.approx(0.0)
    assert lct_area_mean(d, y + 0.5, y) == pytest.approx(0.5)
    # a late driver (lane changes 15 m later) scores the area of two parallelograms
    late = normative_path(d, signs, centers, 1, NormativeModel(15.0, 20.0))
    res = lct_mdev(d, late, signs, centers, 1, model, visibility_m=40.0)
    expected = (15.0 * 3.5 + 15.0 * 7.0) / 400.0
    assert res["adapted_length_per_lane_m"] == pytest.approx(20.0, rel=0.02)
    assert res["mdev_basic_m"] == pytest.approx(expected, rel=1e-3)
    # the adapted model learns the late start and scores the consistent driver ~0
    assert res["adapted_start_before_sign_m"] == pytest.approx(15.0, abs=0.2)
    assert res["mdev_adapted_m"] < 0.02


def _normative_by_sign(d: np.ndarray, signs: list[LctSign], centers: list[float], initial: int, model: NormativeModel) -> np.ndarray:
    """The normative path as its definition reads: each sign in turn ramps every point past its start."""
    y = np.full(d.shape, float(centers[initial]))
    for sign in sorted(signs, key=lambda s: s.d_m):
        start = sign.d_m - model.start_before_sign_m
        end = start + max(model.length_per_lane_m * abs(sign.to_lane - sign.from_lane), 1e-6)
        ramp = np.clip((d - start) / (end - start), 0.0, 1.0)
        y = np.where(d >= start, centers[sign.from_lane] + ramp * (centers[sign.to_lane] - centers[sign.from_lane]), y)
    return y + model.habitual_offset_m


def _fits_by_mask(d: np.ndarray, y: np.ndarray, signs: list[LctSign], centers: list[float], visibility_m: float) -> list[tuple[float, ...]]:
    """`fit_lane_changes` as its definition reads: a boolean window per sign."""
    ordered = sorted(signs, key=lambda s: s.d_m)
    out: list[tuple[float, ...]] = []
    for k, sign in enumerate(ordered):
        shift = centers[sign.to_lane] - centers[sign.from_lane]
        lo = sign.d_m - visibility_m
        hi = ordered[k + 1].d_m - visibility_m if k + 1 < len(ordered) else d[-1]
        mask = (d >= lo) & (d <= hi)
        if shift == 0.0 or not mask.any():
            out.append((math.nan, math.nan, float(sign.from_lane == sign.to_lane), math.nan))
            continue
        frac = (y[mask] - centers[sign.from_lane]) / shift
        reached = float(np.any(np.abs(y[mask] - centers[sign.to_lane]) < 0.25 * abs(shift)))
        i10, i90 = np.flatnonzero(frac >= 0.1), np.flatnonzero(frac >= 0.9)
        if len(i10) == 0 or len(i90) == 0:
            out.append((math.nan, math.nan, reached, math.nan))
            continue
        length = max((d[mask][i90[0]] - d[mask][i10[0]]) / 0.8, 1e-6)
        start = d[mask][i10[0]] - 0.1 * length
        out.append((start, length, reached, start - lo))
    return out


@pytest.mark.parametrize("seed", range(6))
def test_lct_path_and_fits_equal_their_definitions(seed: int) -> None:
    """normative_path looks each point up once and fit_lane_changes slices its windows when
    the distance never decreases; both give exactly what the per-sign definitions give
    (with standing still, driving back and points before the first sign)."""
    from opends_gym.metrics.lct import fit_adapted_model, fit_lane_changes

    rng = np.random.default_rng(seed)
    centers = [3.85, 0.0, -3.85]
    lanes = rng.integers(0, 3, 9)
    signs = [LctSign(float(150 * (k + 1) + rng.uniform(-20, 20)), int(a), int(b)) for k, (a, b) in enumerate(itertools.pairwise(lanes))]
    model = NormativeModel(float(rng.uniform(0, 40)), float(rng.uniform(5, 120)), float(rng.normal(0, 0.3)))  # (ramps may overlap)
    d = np.cumsum(rng.uniform(0.0, 0.5, 3000)) - 60.0
    edges = [s.d_m - model.start_before_sign_m for s in signs] + [s.d_m - 40.0 for s in signs]  # ramps start, windows open
    d = np.sort(np.concatenate([d, edges, edges]))  # points exactly on them, twice
    d[100:140] = d[100]  # standing still
    y = np.cumsum(rng.normal(0, 0.05, len(d)))
    y[np.isin(d, edges)] += 2.0  # (a sample on a window's edge decides its fit)
    for dist in (d, d + np.where(np.arange(len(d)) % 97 == 0, -3.0, 0.0)):  # monotonic, then driving back now and then
        assert np.array_equal(
            normative_path(dist, signs, centers, int(lanes[0]), model), _normative_by_sign(dist, signs, centers, int(lanes[0]), model)
        )
        fits = [(f.start_d_m, f.length_m, float(f.reached_target), f.latency_m) for f in fit_lane_changes(dist, y, signs, centers, 40.0)]
        assert np.array_equal(np.array(fits), np.array(_fits_by_mask(dist, y, signs, centers, 40.0)), equal_nan=True)
        assert fit_adapted_model(dist, y, signs, centers, 40.0, model) == _adapted_by_mask(dist, y, signs, centers, model)


def _adapted_by_mask(d: np.ndarray, y: np.ndarray, signs: list[LctSign], centers: list[float], fallback: NormativeModel) -> NormativeModel:
    """`fit_adapted_model` as its definition reads: the lane-keeping samples by a mask per fitted change."""
    from opends_gym.metrics.lct import fit_lane_changes

    fits = [f for f in fit_lane_changes(d, y, signs, centers, 40.0) if math.isfinite(f.start_d_m)]
    if not fits:
        return fallback
    start_before = float(np.median([f.sign.d_m - f.start_d_m for f in fits]))
    per_lane = float(np.median([f.length_m / max(1, abs(f.sign.to_lane - f.sign.from_lane)) for f in fits]))
    basic = _normative_by_sign(d, signs, centers, signs[0].from_lane, NormativeModel(start_before, per_lane))
    keeping = np.ones(len(d), dtype=bool)
    for f in fits:
        keeping &= ~((d >= f.start_d_m) & (d <= f.start_d_m + f.length_m))
    return NormativeModel(start_before, per_lane, float(np.median(y[keeping] - basic[keeping])) if keeping.any() else 0.0)


@pytest.mark.parametrize("seed", range(4))
def test_lane_keeping_mask_equals_its_definition(seed: int) -> None:
    """Each sample is compared with the nearest lane changes only; the result is that of
    comparing it with all of them, also at exactly the window's distance and when the clock
    stands still or runs backwards."""
    rng = np.random.default_rng(seed)
    n = 4000
    t = np.round(np.arange(n) / 60.0 * 4) / 4  # repeated times, exactly 2.5 s apart from many changes
    lane = np.repeat(rng.integers(-1, 3, n // 40 + 1), 40)[:n].astype(float)
    for clock in (t, t[::-1].copy()):
        for window in (2.5, 0.0, 1.0):
            keep = lane >= 0
            for tc in clock[1:][lane[1:] != lane[:-1]]:
                keep &= np.abs(clock - tc) > window
            assert np.array_equal(lane_keeping_mask(clock, lane, window), keep)


def test_mean_ci() -> None:
    ci = mean_ci([1.0, 2.0, 3.0, 4.0])
    assert ci.mean == pytest.approx(2.5)
    half = t_quantile(0.95, 3) * math.sqrt(5 / 3) / 2
    assert (ci.low, ci.high) == pytest.approx((2.5 - half, 2.5 + half))
    assert t_quantile(0.95, 10) == pytest.approx(2.2281, abs=1e-3)
    assert t_quantile(0.95, 1) == pytest.approx(12.706, abs=1e-3)
    assert mean_ci([float("nan")]).n == 0
