"""The brake and platoon batches' compiled autoresets (`vector.platoon_reset`) and action
check (`vector.platoon_controls`): what they leave to later is what the Python resets did at
once, and a refused action moves no env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

import opends_gym  # noqa: F401  (registers the ids)
from tests.native_helpers import step_both


@pytest.mark.parametrize("env_id", ["OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0"])
def test_world_and_stimulus_seeds_of_autoresets_are_drawn_as_the_single_env_draws_them(env_id: str) -> None:
    """Each reset draws a world seed and then the stimulus generator's seed from the env's
    generator (`World.reset(seed=...)`, `ThreeVehiclePlatoonEnv.reset`): the compiled resets
    leave both draws for when the generator is next read, so it is then where two draws per
    reset leave it, and the episode's stimulus seed is its reset's second draw."""
    n = 200
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=False)
    env.reset(seed=3)
    core = env.unwrapped.shards[0].core
    resets = np.zeros(n, dtype=np.int64)
    env.action_space.seed(1)
    for _ in range(120):
        resets += env.unwrapped._autoreset
        env.step(env.action_space.sample())
    assert resets.max() > 0
    for e in sorted({0, int(np.argmax(resets)), n - 1}):
        expect, _ = seeding.np_random(3 + e)
        for _ in range(1 + int(resets[e])):
            expect.integers(0, 2**31 - 1)
            seed = expect.integers(0, 2**31 - 1)
        got = core.rng(e)
        assert core.prng_seed[e] == seed, e
        assert got.integers(0, 2**62) == expect.integers(0, 2**62), e
    env.close()


def test_a_nan_action_in_a_chunked_brake_batch_moves_no_env() -> None:
    """A lone brake batch of several chunks refuses NaN before any env moves (the env leaves
    the check to it): after the refused step it goes on exactly like a batch that never got
    it; a resetting env's action is not read (NEXT_STEP autoreset)."""
    n = 300
    kw = {"num_envs": n, "vectorization_mode": "vector_entry_point", "record_metrics": False}
    a_env, b_env = gym.make_vec("OpenDS/BrakeReaction-v0", **kw), gym.make_vec("OpenDS/BrakeReaction-v0", **kw)
    assert a_env.unwrapped.shards[0].core.checks_actions
    a_env.reset(seed=5)
    b_env.reset(seed=5)
    a_env.action_space.seed(2)
    ends = 0
    for t in range(60):
        act = a_env.action_space.sample()
        out_a, out_b = step_both(a_env, b_env, act, t)
        for key, value in out_a[4].items():
            assert np.array_equal(value, out_b[4][key], equal_nan=True), (t, key)
        ends += int((out_a[2] | out_a[3]).sum())
    assert ends > 0
