"""The native LCT batch's compiled episode scoring (`metrics.lct_scores`): the single env's floats."""

from __future__ import annotations

import numpy as np
import pytest

from tests.test_vector_native import LCT, run_identity

SWERVE_AT_M = np.array([np.inf, -1.0, 38.0, 30.0, 22.0, 12.0, -1.0, np.inf])  # distance to the revealed sign


def keeper_with_swerves(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Keeps the sign's lane, except that env k steers hard off the road once its revealed
    sign is nearer than SWERVE_AT_M[k] (inf: at once; -1: never), so episodes end before the
    first sign is readable and inside instructed lane changes (the signs' start to the end of
    the basic normative change), before passing the sign."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
    swerve = (SWERVE_AT_M[:n] == np.inf) | ((obs[:, -3] > 0) & (obs[:, -1] < SWERVE_AT_M[:n]))
    a[:, 0] = np.where(swerve, 0.5, a[:, 0])
    return a


def test_episodes_ended_before_passing_a_sign_score_as_the_single_env() -> None:
    """Episodes that end before and inside instructed lane changes (scored in compiled code):
    every metric (SAE J2944 SDLP without the instructed changes, reversal rates, sign counts)
    equals the single env's."""
    seen = run_identity(LCT, keeper_with_swerves, n=8, steps=260, seed=3)
    assert seen["episodes"] >= 8 and seen["correct"] >= 2


def synthetic_episode(rng: np.random.Generator, reverse: bool) -> dict:
    """An LCT-like drive past 18 signs (lane changes ramped near each, noise, a steering
    random walk), d never decreasing, or with `reverse` a stretch driven backwards."""
    from opends_gym.metrics import episode_scores

    n, dt = 4000, 1 / 60
    step = rng.uniform(0.2, 0.5, n)
    if reverse:
        step[1500:1700] = -rng.uniform(0.1, 0.3, 200)
    d = np.cumsum(step) - step[0]
    lane_lat = np.array([-3.75, 0.0, 3.75])
    sign_d = np.arange(1, 19) * 70.0
    lanes = rng.integers(0, 3, 19)
    lanes[1:] = np.where(lanes[1:] == lanes[:-1], (lanes[:-1] + 1) % 3, lanes[1:])
    y = np.full(n, lane_lat[lanes[0]])
    for k, sd in enumerate(sign_d):  # a ramp to the new lane starting 20-35 m before the sign (some missed)
        if rng.random() < 0.85:
            s0 = sd - rng.uniform(20, 35)
            ramp = np.clip((d - s0) / rng.uniform(15, 40), 0, 1)
            y = np.where(d >= s0, lane_lat[lanes[k]] + ramp * (lane_lat[lanes[k + 1]] - lane_lat[lanes[k]]), y)
    start_z = 500.0
    return {
        "t": np.arange(n) * dt, "z": start_z - d, "lat": y + rng.normal(0, 0.15, n), "steer": np.cumsum(rng.normal(0, 0.5, n)),
        "start_z": start_z, "sign_d": sign_d, "sign_from": lanes[:-1].astype(np.int64), "sign_to": lanes[1:].astype(np.int64),
        "lane_lat": lane_lat, "initial_lane": int(lanes[0]),
        "params": episode_scores.scoring_params(60.0, 6.0, (5.625, -5.625)),
    }  # fmt: skip


@pytest.mark.parametrize("reverse", [False, True])
def test_lane_change_fits_and_mdev_as_the_single_envs_functions(reverse: bool) -> None:
    """`lct_lane_changes` (windows and the normative path looked up by sorted search where d
    never decreases, by scanning where it does) gives `metrics.lct`'s fits and MDEV, the
    single env's, on drives past 18 signs, with and without a stretch driven backwards."""
    from opends_gym.metrics.lct import LctSign, NormativeModel, fit_lane_changes, lct_mdev
    from opends_gym.metrics.lct_scores import lct_lane_changes

    for seed in range(4):
        ep = synthetic_episode(np.random.default_rng(seed), reverse)
        d, y, n = ep["start_z"] - ep["z"], ep["lat"], len(ep["z"])
        passed = int(np.sum(ep["sign_d"] <= d[-1]))
        signs = [LctSign(float(ep["sign_d"][k]), int(ep["sign_from"][k]), int(ep["sign_to"][k])) for k in range(passed)]
        basic = NormativeModel(30.0, 25.0)
        fits_ref = fit_lane_changes(d, y, signs, list(ep["lane_lat"]), 40.0)
        ref = lct_mdev(d, y, signs, list(ep["lane_lat"]), ep["initial_lane"], basic, 40.0, fits_ref)
        out, fits = np.full((1, 5), np.nan), np.zeros((1, len(ep["sign_d"]), 2))
        lct_lane_changes(np.array([0, n]), ep["z"], y, ep["start_z"], ep["sign_d"], ep["sign_from"], ep["sign_to"], np.array([passed]),
                         40.0, 30.0, 25.0, ep["lane_lat"], ep["initial_lane"], out, fits)  # fmt: skip
        assert list(out[0]) == [ref[k] for k in ("mdev_basic_m", "mdev_adapted_m", "adapted_start_before_sign_m",
                                                 "adapted_length_per_lane_m", "adapted_habitual_offset_m")]  # fmt: skip
        latencies = [f.latency_m for f in fits_ref]
        np.testing.assert_array_equal(fits[0, :passed, 0], latencies)
        assert list(fits[0, :passed, 1]) == [1.0 if f.reached_target else 0.0 for f in fits_ref]
        assert np.isfinite(latencies).sum() >= 10


@pytest.mark.parametrize("reverse", [False, True])
def test_instructed_changes_by_sorted_search_as_by_scanning(reverse: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """`lct_scores` finds each sign's instructed change and lane by sorted search where d never
    decreases; every key (SAE J2944 SDLP without the instructed changes, reversal rates, sign
    counts) equals what scanning every row for every sign gives (the kernel as Python with
    the sorted search turned off)."""
    from opends_gym.metrics import lct_scores as ls
    from opends_gym.metrics.lct_scores import J2944, lct_scores

    for seed in range(3):
        ep = synthetic_episode(np.random.default_rng(10 + seed), reverse)
        n = len(ep["z"])
        b, a, zi, p, gaps, _, _ = ep["params"]
        args = (np.array([0, n]), ep["t"], ep["z"], ep["lat"], ep["steer"], ep["start_z"], ep["sign_d"], ep["sign_from"], ep["sign_to"],
                40.0, 30.0, 25.0, ep["lane_lat"], ep["initial_lane"], b, a, zi, p, gaps)  # fmt: skip
        fast, scanned = np.empty((1, J2944 + len(gaps) + 3)), np.empty((1, J2944 + len(gaps) + 3))
        lct_scores(*args, fast)
        with monkeypatch.context() as m:
            m.setattr(ls, "_never_decreases", lambda d, lo, hi: False)
            ls.lct_scores.py_func(*args, scanned)
        np.testing.assert_array_equal(fast, scanned)
        assert fast[0, J2944 + len(gaps) + 2] >= 17  # (signs passed)
        assert 0.0 < fast[0, 2] < 1.0  # (a share of the samples excluded as instructed changes)
