"""The compiled generic episode scoring of the native platoon/brake batches equals the single env's."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.envs.trace import COL, Trace
from opends_gym.jit import wait_compiled
from opends_gym.metrics import episode_scores as es
from opends_gym.sim.controls import STEERING_WHEEL_MAX_DEG


def _trace(rng: np.random.Generator, n: int, dt: float) -> dict[str, np.ndarray]:
    """An episode's trace columns: lane changes (few or many), stretches of car following
    (a lead 20-60 m ahead at about the ego's speed) and none (infinite gap), the car off the
    road now and then, its position lost for 25 s (NaN), a steering signal with reversals of
    every size."""
    t = np.arange(n) * dt
    lateral = np.cumsum(rng.normal(0, 0.04, n)) + rng.uniform(-2, 2)
    lateral += np.where(rng.random(n) < 0.002, rng.uniform(-6, 6, n), 0.0).cumsum() * (rng.random() < 0.5)
    if n > 3000:
        start = int(rng.integers(0, n - 2000))
        lateral[start : start + 1500] = np.nan  # (lost position: SAE J2944 segments without enough valid samples)
    lane = np.where(np.abs(lateral) > 5.6, -1, np.floor((lateral + 5.625) / 3.75)).astype(np.float64)
    offset = lateral - (lane * 3.75 - 3.75)
    speed = np.abs(20 + np.cumsum(rng.normal(0, 0.05, n)))
    speed[rng.random(n) < 0.0005] = 2.0  # (below the following speed)
    lead = speed + 3.0 * np.sin(np.cumsum(rng.normal(0, 0.01, n)))  # (within 2.5 m/s of the ego for a while)
    gap = 20 + 40 * rng.random() + np.cumsum(rng.normal(0, 0.1, n))
    cut = np.zeros(n, dtype=bool)
    for start in rng.integers(0, max(n, 1), 3):
        cut[start : start + int(rng.integers(1, 1200))] = True  # no lead for a while
    gap, lead = np.where(cut, np.inf, gap), np.where(cut, np.nan, lead)
    gap[rng.random(n) < 0.0005] = -0.5  # (overlapping bumpers)
    closing = speed - lead
    ttc = np.where(np.isfinite(gap) & (closing > 0), np.maximum(gap, 0.0) / np.where(closing > 0, closing, 1.0), np.inf)
    steering = np.sin(np.cumsum(rng.normal(0, 0.05, n))) * rng.uniform(0.001, 0.1) + rng.normal(0, 1e-3, n)
    return {"t_s": t, "x_m": -lateral, "z_m": -np.cumsum(speed * dt), "speed_mps": speed, "steering": steering, "gap_m": gap,
            "lead_speed_mps": lead, "headway_s": (gap + 4.5) / speed, "ttc_s": ttc, "lateral_m": lateral, "lane_index": lane,
            "lane_offset_m": offset}  # fmt: skip


def test_episode_scores_equal_the_single_envs_episode_metrics() -> None:
    """Episodes of 0 to 3 minutes scored together in one pass (as Python, then compiled) give
    the single env's `episode_metrics` floats for the same traces: SDLP over lane keeping and
    SAE J2944 segments, steering reversal rates, car following, off-road time and exits."""
    env = gym.make("OpenDS/ThreeVehiclePlatoon-v0")
    single = env.unwrapped
    env.reset(seed=0)
    dt = 1.0 / single.config.physics_hz
    rng = np.random.default_rng(4)
    traces = [_trace(rng, n, dt) for n in (1, 2, 3, 4, 12, 700, 2000, 4000, 9000, 11000)]
    expected = []
    for cols in traces:
        tr = Trace(capacity=max(len(cols["t_s"]), 1))
        for name, values in cols.items():
            tr._data[: len(values), COL[name]] = values
        tr.n = tr._stored = len(cols["t_s"])
        single.trace = tr
        expected.append(single.episode_metrics())
    keys = list(es.KEYS)
    assert all(k in expected[0] for k in keys)
    for key in ("sdlp_j2944_m", "thw_mean_s", "steering_reversal_rate_10deg_per_min", "mean_headway_s"):
        assert any(math.isfinite(m[key]) and m[key] > 0 for m in expected), key  # (each part of the scoring has work)
    assert any(m["road_exits"] >= 2 for m in expected) and any(m["sdlp_j2944_segments_valid"] < m["sdlp_j2944_segments"] for m in expected)
    starts = np.cumsum([0] + [len(c["t_s"]) for c in traces])
    cat = {k: np.concatenate([c[k] for c in traces]) for k in traces[0]}
    x, z = cat["x_m"], cat["z_m"]
    cfg = single.config
    limit = len(single.world.road.lanes) * cfg.lane_width_m / 2 + cfg.off_road_margin_m  # (`_off_road_mask`)
    params = es.scoring_params(cfg.physics_hz, limit, single.guide.road_edges_m)
    args = (starts, cat["t_s"], np.hypot(np.diff(x), np.diff(z)), cat["speed_mps"], cat["steering"] * STEERING_WHEEL_MAX_DEG,
            cat["gap_m"], cat["lead_speed_mps"], cat["headway_s"], cat["ttc_s"], cat["lateral_m"], cat["lane_index"],
            cat["lane_offset_m"], *params)  # fmt: skip
    for run in (es.episode_scores.py_func, None):  # as Python, then compiled
        if run is None:
            es.episode_scores(*args, np.empty((len(traces), len(keys))))
            wait_compiled()
            run = es.episode_scores
        out = np.full((len(traces), len(keys)), -1.0)
        run(*args, out)
        for j, want in enumerate(expected):
            got = dict(zip(keys, out[j].tolist(), strict=True))
            for k in keys:
                assert np.array_equal(got[k], want[k], equal_nan=True), (j, k, got[k], want[k])
    env.close()
