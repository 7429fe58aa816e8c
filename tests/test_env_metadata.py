"""Env metadata a wrapper relies on: RecordVideo plays `render_fps` frames per second."""

from __future__ import annotations

import gymnasium as gym
import pytest

import opends_gym  # noqa: F401  (registers the ids)

IDS = sorted(k for k in gym.registry if k.startswith("OpenDS/"))


@pytest.mark.parametrize("env_id", IDS)
def test_render_fps_follows_policy_hz(env_id: str) -> None:
    fast = gym.make(env_id, policy_hz=20)
    default = gym.make(env_id)
    try:
        assert fast.metadata["render_fps"] == 20  # one frame per policy step: real time at 20 Hz
        assert default.metadata["render_fps"] == 10  # the default policy_hz; the instances do not share it
        assert fast.unwrapped.metadata["render_modes"] == ["human", "rgb_array"]
    finally:
        fast.close()
        default.close()
