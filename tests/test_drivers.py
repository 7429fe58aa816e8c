"""Driver models through the agent interface: rule, distracted, policy."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.drivers.agents import make_agent
from opends_gym.drivers.distracted import LEVELS, DistractedDriver, DistractionParams, GlanceProcess, params_for

# The documented bound for the rule driver's LCT MDEV (basic model), see the README.
RULE_LCT_MDEV_BOUND_M = 0.2


def drive(env_id: str, agent: Any, seed: int = 0, **kwargs: Any) -> tuple[dict[str, float], gym.Env]:
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed)
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        if terminated or truncated:
            break
    return info["episode_metrics"], env


def test_rule_driver_passes_the_lane_change_test() -> None:
    m, _env = drive("OpenDS/LaneChangeTest-v0", make_agent("rule"))
    assert m["lane_changes"] == 18 and m["lane_changes_correct"] == 18
    assert m["reactions_correct"] == 18 and m["reactions_missed"] == 0
    assert m["mdev_basic_m"] < RULE_LCT_MDEV_BOUND_M
    assert m["collisions"] == 0


def test_rule_driver_passes_the_reaction_test_with_every_reaction_correct() -> None:
    m, _env = drive("OpenDS/ReactionTest-v0", make_agent("rule"))
    assert m["Brake_n"] == 10 and m["Brake_correct"] == 10
    assert m["LaneChange_n"] == 10 and m["LaneChange_correct"] == 10
    assert m["reactions_failed"] == 0 and m["reactions_missed"] == 0


def test_rule_driver_passes_the_platoon_test() -> None:
    m, env = drive("OpenDS/ThreeVehiclePlatoon-v0", make_agent("rule"))
    assert m["stimuli"] == 10 and m["stimulus_misses"] == 0
    kinds = ("brakeLight", "leadingCarTurnSignal", "followerCarTurnSignal", "speedReduction", "emergencyBrake")
    assert all(st.result == 1 for st in env.unwrapped.platoon.state.stimuli)
    assert sum(m[f"{k}_n"] for k in kinds) == 10
    assert m["collisions"] == 0 and m["lateral_outside_fraction"] == 0
    # outside 20-35 m mostly while the lead brakes or slows, and while catching up after an emergency
    # stop: OpenDS's powertrain needs ~9 s from standstill back to 95 km/h
    assert m["longitudinal_outside_fraction"] < 0.42


def test_rule_driver_passes_the_brake_reaction_test() -> None:
    m, _ = drive("OpenDS/BrakeReaction-v0", make_agent("rule"))
    assert m["stimuli"] + m["BrakeSign_n"] == 9
    assert m["stimulus_misses"] == 0 and m["BrakeSign_correct"] == m["BrakeSign_n"]
    assert 0 < m["brake_onset_s"] < 0.2  # the attentive rule driver brakes within the policy step after onset
    assert m["collisions"] == 0


def test_rule_driver_works_with_buttons_and_meta_actions() -> None:
    m, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("rule"), action="continuous_buttons", max_episode_s=60.0)
    assert m["reactions_correct"] >= 4
    m, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("rule"), action="discrete", max_episode_s=60.0)
    assert m["lane_changes_correct"] >= 4 and m["collisions"] == 0


def test_heavy_distraction_is_measurably_worse_on_mdev_and_reaction_time() -> None:
    attentive_lct, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("distracted:none"), seed=3)
    heavy_lct, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("distracted:heavy"), seed=3)
    assert heavy_lct["mdev_basic_m"] > attentive_lct["mdev_basic_m"] + 0.2
    assert heavy_lct["sdlp_m"] > attentive_lct["sdlp_m"]
    attentive_rt, _ = drive("OpenDS/ReactionTest-v0", make_agent("distracted:none"), seed=3)
    heavy_rt, _ = drive("OpenDS/ReactionTest-v0", make_agent("distracted:heavy"), seed=3)
    assert heavy_rt["Brake_mean_rt_s"] > attentive_rt["Brake_mean_rt_s"] + 0.3


def test_attentive_level_is_the_rule_driver_with_a_human_reaction_time() -> None:
    rule, _ = drive("OpenDS/ReactionTest-v0", make_agent("rule"), max_episode_s=120.0)
    attentive = make_agent("distracted:none")
    human, _ = drive("OpenDS/ReactionTest-v0", attentive, max_episode_s=120.0)
    assert attentive.off_road_s == 0.0  # type: ignore[attr-defined]  (no secondary task, no glances)
    assert human["reactions_correct"] == rule["reactions_correct"] > 0
    # the 0.35 s perception-reaction time, quantised to the 10 Hz policy steps
    assert human["Brake_mean_rt_s"] - rule["Brake_mean_rt_s"] == pytest.approx(0.35, abs=0.1)


def test_distracted_driver_is_deterministic_per_seed() -> None:
    a, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("distracted:heavy"), seed=5, max_episode_s=60.0)
    b, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("distracted:heavy"), seed=5, max_episode_s=60.0)
    c, _ = drive("OpenDS/LaneChangeTest-v0", make_agent("distracted:heavy"), seed=6, max_episode_s=60.0)
    assert a == b
    assert a != c


def test_glance_process_matches_its_duty_cycle_and_glance_lengths() -> None:
    p = DistractionParams(duty_cycle=0.5, task_episode_s=6.0, glance_mean_s=1.5, glance_sd_s=0.4, on_road_glance_s=1.0)
    g = GlanceProcess(p, np.random.default_rng(0))
    dt = 0.05
    off = np.array([g.eyes_off_road(k * dt) for k in range(int(4000 / dt))])
    # busy half the time, and while busy 1.5 s away per 1.0 s on the road: ~0.5 * 0.6 off road
    assert off.mean() == pytest.approx(0.5 * 1.5 / 2.5, abs=0.05)
    edges = np.flatnonzero(np.diff(off.astype(int)))
    runs = np.diff(edges)[::2] * dt if off[edges[0] + 1] else np.diff(edges)[1::2] * dt
    assert np.mean(runs) == pytest.approx(1.5, abs=0.2)


def test_glances_are_deferred_during_a_manoeuvre() -> None:
    g = GlanceProcess(DistractionParams(duty_cycle=0.9, task_episode_s=5.0), np.random.default_rng(1))
    assert not any(g.eyes_off_road(k * 0.1, may_look_away=False) for k in range(200))
    assert any(g.eyes_off_road(20.0 + k * 0.1) for k in range(200))


def test_distraction_levels_and_interpolation() -> None:
    assert params_for("heavy") == LEVELS["heavy"]
    assert params_for("0") == LEVELS["none"]
    assert params_for("1") == replace(LEVELS["heavy"], task_episode_s=params_for("1").task_episode_s, on_road_glance_s=1.0)
    half = params_for("0.5")
    assert half.duty_cycle == pytest.approx(0.5 * LEVELS["heavy"].duty_cycle)
    with pytest.raises(ValueError, match="unknown distraction level"):
        params_for("extreme")
    with pytest.raises(ValueError, match="in \\[0, 1\\]"):
        params_for("1.5")
    with pytest.raises(ValueError, match="duty_cycle"):
        DistractionParams(duty_cycle=1.0)


def test_unknown_agent_names_the_known_ones() -> None:
    with pytest.raises(ValueError, match="rule"):
        make_agent("clever")


def test_distracted_wraps_a_non_percept_driver_with_stale_observations() -> None:
    seen: list[np.ndarray] = []

    class Recorder:
        name = "recorder"

        def reset(self, env: gym.Env, seed: int) -> None:
            self.env = env

        def act(self, obs: Any, info: dict[str, Any]) -> Any:
            seen.append(np.array(obs))
            return np.zeros(2, dtype=np.float32)

    d = DistractedDriver(DistractionParams(duty_cycle=0.9, task_episode_s=30.0, glance_mean_s=2.0), base=Recorder())
    m, _ = drive("OpenDS/LaneChangeTest-v0", d, seed=2, max_episode_s=30.0)
    repeats = sum(1 for a, b in itertools.pairwise(seen) if np.array_equal(a, b))
    assert repeats > 10  # frozen observations during glances away
    assert math.isfinite(m["duration_s"])
