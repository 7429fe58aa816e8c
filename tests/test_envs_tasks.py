"""Task-level behaviour of the envs: LCT scoring, the DRT wrapper, headless frames for every id."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401
from opends_gym.drivers.rule import RuleDriver, RuleParams
from opends_gym.envs import ENVS
from opends_gym.envs.drt import DetectionResponseTask


def _episode(env: gym.Env[Any, Any], driver: Any, seed: int = 0) -> dict[str, float]:
    obs, info = env.reset(seed=seed)
    driver.reset(env, seed)
    while True:
        obs, _, terminated, truncated, info = env.step(driver.act(obs, info))
        if terminated or truncated:
            return dict(info["episode_metrics"])


def test_lct_perfect_driver_scores_near_zero_and_a_late_driver_clearly_worse() -> None:
    env = gym.make("OpenDS/LaneChangeTest-v0")
    on_time = _episode(env, RuleDriver())
    # the same driver starting each lane change only 5 m before the sign (25 m late)
    late = _episode(env, RuleDriver(RuleParams(lane_change_start_before_sign_m=5.0)))
    assert on_time["mdev_basic_m"] < 0.2
    assert late["mdev_basic_m"] > on_time["mdev_basic_m"] + 0.4
    # the adapted model absorbs a consistent personal timing, the basic one does not
    assert late["mdev_adapted_m"] < late["mdev_basic_m"]
    assert late["adapted_start_before_sign_m"] < on_time["adapted_start_before_sign_m"] - 15.0


class _Responder:
    """Drives straight and presses the reaction button `delay_steps` policy steps after each DRT onset."""

    def __init__(self, delay_steps: int | None) -> None:
        self.delay_steps = delay_steps

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.on_for = 0

    def act(self, obs: Any, info: dict[str, Any]) -> np.ndarray:
        self.on_for = self.on_for + 1 if info.get("drt_stimulus_on") else 0
        press = self.delay_steps is not None and self.on_for == self.delay_steps
        return np.array([0.0, 0.0, 1.0 if press else -1.0, -1.0, -1.0, -1.0], dtype=np.float32)


def test_drt_wrapper_scores_hits_misses_and_reaction_times() -> None:
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", max_episode_s=60.0))
    quick = _episode(env, _Responder(delay_steps=3))
    assert quick["drt_stimuli"] >= 11  # one every 3-5 s over 60 s
    assert quick["drt_hit_rate"] == 1.0 and quick["drt_misses"] == 0
    # seen on the policy step after onset, pressed 3 steps later, scored to the physics step
    assert 0.2 <= quick["drt_mean_rt_s"] <= 0.45
    silent = _episode(env, _Responder(delay_steps=None))
    assert silent["drt_hits"] == 0 and silent["drt_hit_rate"] == 0.0
    assert silent["drt_misses"] == silent["drt_stimuli"]


def test_drt_schedule_is_seeded() -> None:
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", max_episode_s=30.0))
    a = _episode(env, _Responder(2), seed=4)
    b = _episode(env, _Responder(2), seed=4)
    c = _episode(env, _Responder(2), seed=5)
    assert a == b
    assert env.unwrapped is not None and a["drt_stimuli"] > 0 and (a != c)


@pytest.mark.parametrize("env_id", sorted(ENVS))
def test_every_env_renders_headless_frames_that_are_not_blank(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array", max_episode_s=10.0, render_width=160, render_height=90)
    env.reset(seed=0)
    for _ in range(5):
        # random full-lock steering (1 rad at the wheels, as OpenDS) can end a fast episode within 5 steps
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    frame = env.render()
    assert isinstance(frame, np.ndarray) and frame.shape == (90, 160, 3) and frame.dtype == np.uint8
    colours, counts = np.unique(frame.reshape(-1, 3), axis=0, return_counts=True)
    assert len(colours) >= 4  # ground, road or markings, the ego car, ...
    assert counts.max() < 0.97 * counts.sum()  # no single colour fills the frame
    env.close()


class _EdgeHugger:
    """Drives the whole LCT along the road's right edge, ignoring the signs."""

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.env = env.unwrapped

    def act(self, obs: Any, info: dict[str, Any]) -> np.ndarray:
        from opends_gym.control.controllers import stanley_steering

        s = self.env.world.ego.state
        p = self.env.guide.locate(s.x, s.z)
        edge = -(self.env.half_road - 0.2)  # + left: the right edge, 0.2 m inside
        return np.array([stanley_steering(s.yaw, p.heading_rad, p.lateral_m, edge, s.u, s.r), 0.0], dtype=np.float32)


def test_lct_signs_and_the_end_trigger_span_the_whole_road() -> None:
    env = gym.make("OpenDS/LaneChangeTest-v0")
    m = _episode(env, _EdgeHugger())
    events = env.unwrapped.world.events
    assert sum(1 for e in events if e.kind == "trigger" and e.source.endswith("_Trigger") and "Sign" in e.source) == 18
    assert m["duration_s"] < 200.0  # the end trigger ended it (no 300 s truncation)


def test_brake_test_ttc_shaping_penalises_closing_in_on_the_lead() -> None:
    """Full throttle into the lead car: the shaped reward is lower exactly while the TTC is short."""
    shaped = gym.make("OpenDS/BrakeReaction-v0", policy_hz=10)
    plain = gym.make("OpenDS/BrakeReaction-v0", policy_hz=10, reward_ttc_weight=0.0)
    shaped.reset(seed=3)
    plain.reset(seed=3)
    gas = np.array([0.0, 1.0], dtype=np.float32)
    penalties: list[tuple[float, float]] = []
    for _ in range(300):
        _, r_shaped, term, trunc, info = shaped.step(gas)
        _, r_plain, term_p, _, info_p = plain.step(gas)
        assert term_p == term
        assert info["ttc_s"] == info_p["ttc_s"]  # the shaping changes the reward only
        penalties.append((r_plain - r_shaped, info["ttc_s"]))
        if term or trunc:
            break
    assert info["collisions"] >= 1  # it did run into the lead
    assert all(p >= 0.0 for p, _ in penalties)
    close = [p for p, ttc in penalties if ttc < 2.0]
    assert close and all(p > 0.0 for p in close)
    assert max(close) <= 1.0 + 1e-9  # at most the weight per policy step
    far = [p for p, ttc in penalties if ttc >= 3.0]  # closing in monotonically: the whole step was at >= 3 s
    assert far and all(p == 0.0 for p in far)
    shaped.close()
    plain.close()


@pytest.mark.parametrize("end_when_past_lead", [True, False])
def test_overtaking_the_lead_car_ends_the_brake_test(end_when_past_lead: bool) -> None:
    """Passing the car whose brake lights are the stimuli voids the test: the episode ends
    with the task penalty as soon as the ego draws level (unless switched off)."""
    env = gym.make("OpenDS/BrakeReaction-v0", end_when_past_lead=end_when_past_lead)
    obs, _ = env.reset(seed=3)
    core: Any = env.unwrapped
    lead_gaps, rewards, ended = [], [], False
    for _ in range(600):  # into the left lane at full throttle
        steer = float(np.clip(-0.05 * (obs[3] - 1.875) - 0.8 * obs[1], -1, 1))
        obs, r, terminated, truncated, info = env.step(np.array([steer, 1.0], dtype=np.float32))
        lead_gaps.append(core.platoon._distance_to(core.platoon.lead))
        rewards.append(r)
        if terminated or truncated:
            ended = True
            break
    assert info["collisions"] == 0 and abs(obs[3] - 1.875) < 0.5  # overtook cleanly in the other lane
    if end_when_past_lead:
        assert ended and terminated and lead_gaps[-1] < 0.0 < lead_gaps[-2]
        assert rewards[-1] < -40.0  # the task penalty (50) on the last step
    else:
        assert not ended and lead_gaps[-1] < -20.0
    env.close()
