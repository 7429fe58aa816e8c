"""The native batch of `OpenDS/DrivingTask-v0` with traffic (MotorwayTask): same results as the single env."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.vector import NativeVectorEnv

from .conftest import CORPUS
from .test_vector_native import _compare_infos, _same

TASK = "OpenDS/DrivingTask-v0"
MOTORWAY = str(CORPUS / "opends-cts" / "MotorwayTask")


def lane_keeper(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Steers onto the route's lane centre (heading error, lane offset), holds ~90 km/h, with noise."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 0] = np.clip(-0.8 * obs[:, 2] - 1.0 * obs[:, 1], -1.0, 1.0) + rng.normal(0.0, 0.05, n)
    a[:, 1] = np.where(obs[:, 0] < 25.0, 0.6, 0.0) + rng.normal(0.0, 0.1, n)
    return np.clip(a, -1.0, 1.0)


def run_lockstep(n: int, steps: int, seed: int, history_steps: int = 0, **kwargs: Any) -> dict[str, float]:
    """Step the native batch and SyncVectorEnv of single envs in lockstep; compare observations
    (ego pose features and the nearest traffic cars), rewards, flags, info and episode metrics.
    Also counts the env-steps whose traffic followed the shared history (`following`) and the
    others (`own`); `history_steps` > 0 keeps that many history entries."""
    native = gym.make_vec(TASK, num_envs=n, vectorization_mode="vector_entry_point", task=MOTORWAY, **kwargs)
    sync = gym.make_vec(TASK, num_envs=n, vectorization_mode="sync", task=MOTORWAY, **kwargs)
    assert isinstance(native.unwrapped, NativeVectorEnv)
    traffic = native.unwrapped.shards[0].core.traffic  # type: ignore[attr-defined]
    if history_steps:
        traffic.history.max_steps = history_steps
    rng = np.random.default_rng(seed)
    obs, info = native.reset(seed=seed)
    obs_s, info_s = sync.reset(seed=seed)
    _same("reset obs", obs, obs_s)
    _compare_infos(-1, info, info_s, n)
    seen = {"episodes": 0.0, "collisions": 0.0, "stimuli": 0.0, "cars_seen": 0.0, "km": 0.0, "following": 0.0, "own": 0.0}
    for t in range(steps):
        a = lane_keeper(obs, rng, n)
        obs, r, term, trunc, info = native.step(a)
        seen["following"] += float(np.sum(traffic.shared))
        seen["own"] += float(np.sum(~traffic.shared))
        obs_s, r_s, term_s, trunc_s, info_s = sync.step(a)
        _same(f"step {t} obs", obs, obs_s)
        _same(f"step {t} reward", r, r_s)
        _same(f"step {t} terminated", term, term_s)
        _same(f"step {t} truncated", trunc, trunc_s)
        _compare_infos(t, info, info_s, n)
        seen["episodes"] += float(np.sum(term | trunc))
        seen["collisions"] += float(np.sum(info["new_collisions"]))
        seen["cars_seen"] += float(np.sum(obs[:, 7] > 0.0))  # the first nearby-vehicle slot is taken
        if "episode_metrics" in info:
            m = info["episode_metrics"]
            seen["stimuli"] += float(np.sum(m["stimuli_presented"][info["_episode_metrics"]]))
            seen["km"] += float(np.sum(m["distance_m"][info["_episode_metrics"]])) / 1000.0
    native.close()
    sync.close()
    return seen


def test_motorway_task_identical_to_single_env() -> None:
    """41 road-network cars, the slip road's route lanes, trigger boxes and collisions (the
    lane keeper meets a motorway car at the merge, which ends the episode): bit for bit."""
    seen = run_lockstep(n=3, steps=320, seed=7)
    assert seen["episodes"] >= 3 and seen["collisions"] >= 3 and seen["stimuli"] >= 3 and seen["cars_seen"] > 0
    assert seen["following"] > 0 and seen["own"] > 0  # (worlds left the shared traffic when a car saw their ego car)


def test_worlds_past_the_traffic_history_step_their_own_cars() -> None:
    """A world whose episode outlasts the kept history (here 100 physics steps) takes the state
    of its last entry and steps its cars itself: still bit for bit."""
    seen = run_lockstep(n=2, steps=60, seed=5, history_steps=100, terminate_on_collision=False)
    assert seen["own"] > 0 and seen["following"] > 0


def test_motorway_task_long_drives_identical_to_single_env() -> None:
    """Without ending on collisions the cars drive on along the motorway past the triggers to the
    time limit (truncation, autoreset): still bit for bit."""
    seen = run_lockstep(n=2, steps=450, seed=3, terminate_on_collision=False, max_episode_s=40.0)
    assert seen["episodes"] >= 2 and seen["km"] > 0.5 and seen["stimuli"] >= 2


def test_tasks_the_batch_cannot_run_are_refused_in_one_line() -> None:
    """Refused by default too (the native batch is `make_vec`'s default mode for the id), with the
    feature named and the mode that runs the task."""
    with pytest.raises(ValueError, match=r"needs a task with traffic.*vectorization_mode='sync'") as err:
        gym.make_vec(TASK, num_envs=2, task="ReactionTest")
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="trigger 'collideWithTrafficLightBox', action 'reportSpeed' \\(line 96\\): not supported"):
        gym.make_vec(TASK, num_envs=2, vectorization_mode="vector_entry_point", task=str(CORPUS / "opends-cts" / "Idealtest2"))
    sync = gym.make_vec(TASK, num_envs=2, vectorization_mode="sync", task="ReactionTest")
    assert sync.reset(seed=0)[0].shape[0] == 2
    sync.close()


def test_parallel_chunks_step_each_env_as_alone() -> None:
    """A batch of two chunks (its worlds' traffic on numba's threads) gives its first and last
    env what a batch of that env alone gives for the same seed and actions."""
    n, steps = 130, 60
    kw: dict[str, Any] = {"task": MOTORWAY, "record_metrics": False}
    big = gym.make_vec(TASK, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    alone = [gym.make_vec(TASK, num_envs=1, vectorization_mode="vector_entry_point", **kw) for _ in range(2)]
    assert big.unwrapped.shards[0].core.traffic.parallel  # type: ignore[attr-defined]
    rng = np.random.default_rng(5)
    obs, _ = big.reset(seed=11)
    solo = [a.reset(seed=11 + e)[0] for a, e in zip(alone, (0, n - 1))]
    for t in range(steps):
        act = lane_keeper(obs, rng, n)
        obs, r, term, _, _ = big.step(act)
        for a, e, k in zip(alone, (0, n - 1), range(2)):
            solo[k], r1, term1, _, _ = a.step(act[e : e + 1])
            _same(f"step {t} env {e} obs", obs[e : e + 1], solo[k])
            _same(f"step {t} env {e} reward", r[e : e + 1], r1)
            _same(f"step {t} env {e} terminated", term[e : e + 1], term1)
    big.close()
    for a in alone:
        a.close()


def test_thread_shards_step_like_one_shard() -> None:
    """`threads=2` (each shard's traffic kernel serial, numba's thread pool entered by one
    caller at a time) gives what one shard gives."""
    n, kw = 300, {"task": MOTORWAY, "record_metrics": False}
    one = gym.make_vec(TASK, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    two = gym.make_vec(TASK, num_envs=n, vectorization_mode="vector_entry_point", threads=2, **kw)
    assert one.unwrapped.shards[0].core.parallel  # type: ignore[attr-defined]
    assert [s.core.parallel for s in two.unwrapped.shards] == [False, False]  # type: ignore[attr-defined]
    rng = np.random.default_rng(2)
    obs, _ = one.reset(seed=4)
    obs2, _ = two.reset(seed=4)
    for t in range(25):
        a = lane_keeper(obs, rng, n)
        obs, r, *_ = one.step(a)
        obs2, r2, *_ = two.step(a)
        _same(f"step {t} obs", obs, obs2)
        _same(f"step {t} reward", r, r2)
    one.close()
    two.close()
