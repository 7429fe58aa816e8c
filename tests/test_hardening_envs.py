"""Bad actions and bad options (issue 21, cases 5 and 6): a clear ValueError, and a native
batch that refuses a bad action steps none of its shards."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)

LCT = "OpenDS/LaneChangeTest-v0"
PLATOON = "OpenDS/ThreeVehiclePlatoon-v0"
BRAKE = "OpenDS/BrakeReaction-v0"
SHORT = {"stimuli": 3, "lead_in_m": 100.0, "max_episode_s": 24.0}


@pytest.mark.parametrize(
    ("env_id", "kwargs", "size"),
    [(PLATOON, SHORT, 6), (BRAKE, {"stimuli": 3}, 2), (LCT, {"signs": 3}, 2), (LCT, {"signs": 3, "action": "continuous_buttons"}, 6)],
)
def test_wrong_length_actions_are_refused_naming_the_shape(env_id: str, kwargs: dict, size: int) -> None:
    env = gym.make(env_id, disable_env_checker=True, **kwargs)
    env.reset(seed=0)
    t0 = env.unwrapped.world.t_s
    for n in sorted({2, 3, size - 1, size + 1} - {size}):
        with pytest.raises(ValueError, match=rf"shape \({size},\)"):
            env.step(np.zeros(n, dtype=np.float32))
    with pytest.raises(ValueError, match=rf"shape \({size},\)"):
        env.step(np.zeros((1, size), dtype=np.float32))  # extra axes are not flattened away silently
    assert env.unwrapped.world.t_s == t0  # nothing stepped
    obs, *_ = env.step(np.zeros(size, dtype=np.float32))
    assert env.unwrapped.world.t_s > t0 and np.isfinite(obs).all()
    env.close()


@pytest.mark.parametrize("action", [np.nan, 2.5, -1, 5, True, "1", np.array([1, 2])])
def test_bad_discrete_actions_are_refused(action: object) -> None:
    env = gym.make(LCT, disable_env_checker=True, signs=3, action="discrete")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"discrete action must be one whole number 0\.\.4"):
        env.step(action)
    env.step(np.int64(3))
    env.step(2.0)
    env.close()


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("physics_hz", math.nan, "physics_hz must be finite"),
        ("physics_hz", math.inf, "physics_hz must be finite"),
        ("physics_hz", 1e12, "physics_hz must be at most"),
        ("physics_hz", 0.5, "physics_hz must be at least 1 Hz"),
        ("policy_hz", 0.0, "policy_hz must be positive"),
        ("max_episode_s", -1.0, "max_episode_s must be positive"),
        ("max_episode_s", "60", "max_episode_s must be a number"),
        ("image_width", 84.5, "image_width must be a whole number"),
        ("rays", -3, "rays must not be negative"),
        ("signs", math.nan, "signs must be a whole number"),
        ("lane_width_m", math.inf, "lane_width_m must be finite"),
    ],
)
def test_bad_config_numbers_give_a_clear_error(option: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make(LCT, disable_env_checker=True, **{option: value})


@pytest.mark.parametrize("dt_s", [math.nan, math.inf, 0.0, -0.01, 2.0])
def test_a_world_step_must_be_a_sane_number_of_seconds(dt_s: float) -> None:
    from opends_gym.sim.world_config import WorldConfig

    with pytest.raises(ValueError, match=r"WorldConfig\.dt_s must be"):
        WorldConfig(dt_s=dt_s)


@pytest.mark.parametrize("shards", [{"threads": 2}, {"processes": 2}])
def test_a_bad_action_in_a_later_shard_steps_no_shard(shards: dict[str, int]) -> None:
    env = gym.make_vec(LCT, num_envs=4, vectorization_mode="vector_entry_point", signs=3, **shards)
    assert len(env.unwrapped.shards) == 2
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros((4, 2), dtype=np.float32))
    before = np.asarray(info["sim_time_s"]).copy()
    bad = np.zeros((4, 2), dtype=np.float32)
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="env 3: action contains NaN"):
        env.step(bad)
    _, _, _, _, info = env.step(np.zeros((4, 2), dtype=np.float32))
    after = np.asarray(info["sim_time_s"])
    assert np.allclose(after - before, after[0] - before[0]) and after[0] > before[0]  # still in step
    with pytest.raises(ValueError, match="actions must be numbers"):
        env.step(np.full((4, 2), "x"))
    env.close()
