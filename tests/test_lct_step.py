"""The LCT batch's one-pass step (`vector.lct_step.lct_step`): what it leaves to later or
does in compiled code is what the Python steps did."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

import opends_gym  # noqa: F401  (registers the ids)
from tests.native_helpers import step_both

LCT = "OpenDS/LaneChangeTest-v0"
SHORT = {"signs": 3, "lead_in_m": 100.0, "lead_out_m": 60.0, "max_episode_s": 6.0}


def _batch(n: int, **kw: Any) -> Any:
    return gym.make_vec(LCT, num_envs=n, vectorization_mode="vector_entry_point", **SHORT, **kw)


def _steer(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.uniform(-1.0, 1.0, (n, 2)).astype(np.float32)
    a[:, 0] *= 0.3
    return a


def test_a_nan_action_in_a_chunked_batch_moves_no_env() -> None:
    """A lone batch of several chunks refuses NaN before any env moves: after the refused
    step it goes on exactly like a batch that never got it; a resetting env's action is not
    read (NEXT_STEP autoreset)."""
    n = 300
    a_env, b_env = _batch(n), _batch(n)
    assert a_env.unwrapped.shards[0].core.parallel  # (more than one chunk: `lct_step` on numba's threads)
    rng = np.random.default_rng(2)
    a_env.reset(seed=5)
    b_env.reset(seed=5)
    ends = 0
    for t in range(90):
        act = _steer(rng, n)
        out_a, out_b = step_both(a_env, b_env, act, t)
        for key, value in out_a[4].items():
            if key != "episode_metrics":
                assert np.array_equal(value, out_b[4][key], equal_nan=True), (t, key)
        ends += int((out_a[2] | out_a[3]).sum())
    assert ends > 0


def test_world_seeds_of_compiled_resets_are_drawn_as_the_python_resets_drew_them() -> None:
    """Each reset draws a world seed from the env's generator (`World.reset(seed=...)`): the
    compiled resets leave the draws for later, so an env's generator, when read, is where
    one draw per reset leaves it."""
    n = 260
    env = _batch(n, record_metrics=False)
    env.reset(seed=11)
    core = env.unwrapped.shards[0].core
    resets = np.zeros(n, dtype=np.int64)
    rng = np.random.default_rng(0)
    for _ in range(80):
        resets += env.unwrapped._autoreset
        env.step(_steer(rng, n))
    assert resets.max() > 0
    for e in [0, int(np.argmax(resets)), n - 1]:
        expect, _ = seeding.np_random(11 + e)
        for _ in range(1 + int(resets[e])):
            expect.integers(0, 2**31 - 1)
        assert core.rng(e).integers(0, 2**62) == expect.integers(0, 2**62), e
