"""Batched driver views: N worlds drawn in one frame give each world's single driver view."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401
from opends_gym.render import batch_view, make_renderer
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR


def test_native_lct_batch_images_equal_the_single_envs_pixel_for_pixel() -> None:
    n, steps = 3, 108
    kw = {"observation": "driver_view", "max_episode_s": 10.0}  # truncated after 100 steps: an autoreset inside the run
    venv = gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make("OpenDS/LaneChangeTest-v0", **kw) for _ in range(n)]
    obs, _ = venv.reset(seed=7)
    want = [e.reset(seed=7 + i)[0] for i, e in enumerate(singles)]
    assert obs.shape == (n, 84, 84, 3) and obs.dtype == np.uint8 and venv.observation_space.contains(obs)
    rng = np.random.default_rng(0)
    ended = np.zeros(n, dtype=bool)
    resets, sign_frames = 0, 0
    for t in range(steps):
        for i in range(n):
            assert np.array_equal(obs[i], want[i]), f"step {t}, env {i}: {(obs[i] != want[i]).any(-1).sum()} pixels differ"
        actions = np.stack([[0.0, 1.0], [0.4, 1.0], [rng.uniform(-0.2, 0.2), rng.uniform(0.0, 1.0)]]).astype(np.float32)
        obs, reward, terminated, truncated, _ = venv.step(actions)
        for i, env in enumerate(singles):
            if ended[i]:
                want[i] = env.reset()[0]
                resets += 1
                continue
            want[i], r, term, trunc, _ = env.step(actions[i])
            assert (r, term, trunc) == (reward[i], terminated[i], truncated[i])
        ended = terminated | truncated
        sign_frames += any(o.visible and o.id.startswith("LCT_Sign") for o in singles[0].unwrapped.world.objects.objects)
    assert resets >= 1
    assert sign_frames >= 3  # env 0 drove at full throttle: frames with its first sign pair revealed were compared
    venv.close()


def test_batch_view_equals_single_views_with_traffic_and_weather(monkeypatch: pytest.MonkeyPatch) -> None:
    """The platoon's cars drawn in the batch as alone; a foggy world is drawn on its own (its depth pass)."""
    monkeypatch.setattr(batch_view, "STRIP_VIEWS", 2)  # three views in two buffers
    worlds = [World(BUNDLED_DIR / "ThreeVehiclePlatoon") for _ in range(3)]
    for k, w in enumerate(worlds):
        w.run(1.0 + k)
    worlds[1].triggers.weather["fog_percent"] = 80.0
    batch = batch_view.BatchDriverView(worlds, 96, 64)
    frames = batch.render()
    assert frames.shape == (3, 64, 96, 3)
    for k, w in enumerate(worlds):
        assert np.array_equal(frames[k], make_renderer("driver_view", w).render(96, 64)), f"world {k}"
    assert not np.array_equal(frames[0], frames[2])  # (different states, different pictures)
    worlds[1].triggers.weather["fog_percent"] = -1.0  # the fog lifts: back into the batch frame
    assert np.array_equal(batch.render()[1], make_renderer("driver_view", worlds[1]).render(96, 64))
    batch.close()
