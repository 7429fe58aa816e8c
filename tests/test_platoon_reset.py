"""The brake and platoon batches' compiled autoresets (`vector.platoon_reset`): what they
leave to later is what the Python resets did at once."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

import opends_gym  # noqa: F401  (registers the ids)


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
