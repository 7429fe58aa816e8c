"""Every registered environment follows the Gymnasium and SB3 API to the letter."""

from __future__ import annotations

import multiprocessing as mp
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import opends_gym
from opends_gym.envs import ENVS

# short episodes keep the suite fast; every id accepts these options
FAST = {"max_episode_s": 20.0}
IDS = sorted(ENVS)

# Warnings we accept from the checkers, each with its reason.
ALLOWED_WARNINGS = (
    # our vector observations are unbounded SI quantities (documented units); SB3 suggests
    # normalising, which users do with VecNormalize / NormalizeObservation
    "observation space",
    "We recommend you to use a symmetric and normalized Box action space",  # not emitted: ours is [-1, 1]
)


def _make(env_id: str, **kwargs):  # type: ignore[no-untyped-def]
    return gym.make(env_id, **{**FAST, **kwargs})


def _check_warnings(record: list[warnings.WarningMessage]) -> None:
    bad = [str(w.message) for w in record if not any(a in str(w.message) for a in ALLOWED_WARNINGS)]
    assert not bad, bad


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_env(env_id: str) -> None:
    env = _make(env_id)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        gym_check_env(env.unwrapped, skip_render_check=True)
    _check_warnings(record)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id: str) -> None:
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = _make(env_id)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sb3_check_env(env.unwrapped, warn=True)
    _check_warnings(record)
    env.close()


def _rollout(env_id: str, seed: int, steps: int = 200) -> tuple[np.ndarray, list[float], list[dict]]:
    env = _make(env_id)
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    observations, rewards, infos = [obs], [], []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        observations.append(obs)
        rewards.append(r)
        infos.append({k: v for k, v in info.items() if k not in ("events", "episode_metrics")})
        if term or trunc:
            obs, _ = env.reset()
    env.close()
    return np.array(observations), rewards, infos


@pytest.mark.parametrize("env_id", IDS)
def test_seeded_rollout_is_deterministic(env_id: str) -> None:
    a = _rollout(env_id, seed=7)
    b = _rollout(env_id, seed=7)
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1]
    assert [str(i) for i in a[2]] == [str(i) for i in b[2]]


@pytest.mark.parametrize("env_id", IDS)
def test_pickle_round_trip(env_id: str) -> None:
    env = _make(env_id).unwrapped
    clone = pickle.loads(pickle.dumps(env))
    assert clone.observation_space == env.observation_space
    assert clone.action_space == env.action_space
    o1, _ = env.reset(seed=3)
    o2, _ = clone.reset(seed=3)
    np.testing.assert_array_equal(o1, o2)
    env.action_space.seed(3)
    for _ in range(20):  # the clone observes its own world, not the original's
        a = env.action_space.sample()
        o1 = env.step(a)[0]
        o2 = clone.step(a)[0]
        np.testing.assert_array_equal(o1, o2)
    assert clone.world is not env.world and clone.world.t_s == env.world.t_s


def _make_in_child(env_id: str) -> tuple[int, ...]:
    env = gym.make(f"opends_gym:{env_id}", max_episode_s=5.0)
    obs, _ = env.reset(seed=0)
    env.close()
    return tuple(obs.shape)


@pytest.mark.parametrize("method", ["spawn", "forkserver"])
def test_make_in_fresh_subprocess(method: str) -> None:
    ctx = mp.get_context(method)
    with ctx.Pool(1) as pool:
        shapes = pool.map(_make_in_child, IDS)
    assert all(len(s) >= 1 for s in shapes)


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_envs_batch_infos(mode: str) -> None:
    env_id = "OpenDS/LaneChangeTest-v0"
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode, **FAST)
    obs, infos = envs.reset(seed=[1, 2])
    assert obs.shape[0] == 2
    for _ in range(5):
        obs, _, _, _, infos = envs.step(envs.action_space.sample())
    for key in (
        "sim_time_s",
        "speed_kmh",
        "lateral_offset_m",
        "lane_index",
        "fuel_used_l",
        "collisions",
        "reaction_result",
        "reaction_time_s",
        "mean_deviation_m",
        "sdlp_m",
        "headway_s",
        "ttc_s",
    ):
        assert key in infos, key
        assert np.asarray(infos[key]).shape == (2,)
        assert np.issubdtype(np.asarray(infos[key]).dtype, np.number), key
    envs.close()


def test_registration_is_idempotent() -> None:
    before = {k: v.entry_point for k, v in gym.registry.items() if k.startswith("OpenDS/")}
    opends_gym.register_envs()
    after = {k: v.entry_point for k, v in gym.registry.items() if k.startswith("OpenDS/")}
    assert before == after and set(ENVS) <= set(after)


def test_unknown_option_is_an_error() -> None:
    with pytest.raises(TypeError, match=r"polcy_hz for LaneChangeTestConfig \(did you mean policy_hz\?\)"):
        gym.make("OpenDS/LaneChangeTest-v0", polcy_hz=20)


def test_nan_action_is_rejected_with_a_clear_error() -> None:
    env = _make("OpenDS/LaneChangeTest-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.array([np.nan, 0.0], dtype=np.float32))
