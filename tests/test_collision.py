"""Collisions: `on_collision` terminate | recover | continue, and the exposure a brake test
reports when its driver never brakes (issue: exposure, not survival)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.drivers.agents import make_agent
from opends_gym.study.config import load_study
from opends_gym.study.design import expand

from .conftest import CORPUS

BRAKE = "OpenDS/BrakeReaction-v0"


def _never_brakes(env: gym.Env[Any, Any], seed: int, steps: int = 10_000, gas: float = 0.3) -> tuple[list[dict[str, Any]], bool, bool]:
    """The rule driver's steering with its foot always on the gas (at least `gas`): it runs
    into the lead car at every hard brake. Returns every step's info, terminated, truncated."""
    agent = make_agent("rule")
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed)
    infos = []
    terminated = truncated = False
    for _ in range(steps):
        a = np.array(agent.act(obs, info), dtype=np.float32)
        a[1] = max(a[1], gas)
        obs, _, terminated, truncated, info = env.step(a)
        infos.append(info)
        if terminated or truncated:
            break
    return infos, terminated, truncated


def _metrics(seed: int) -> dict[str, float]:
    env = gym.make(BRAKE, on_collision="recover", on_road_exit="recover")
    infos, terminated, truncated = _never_brakes(env, seed)
    base: Any = env.unwrapped
    assert terminated and not truncated and base.world.triggers.paused, "the task's end trigger ends the drive, not a collision"
    signs = sum(1 for oid in base.world.objects.by_id if oid.endswith("_Sign"))
    m = dict(infos[-1]["episode_metrics"])
    m["signs_in_task"] = float(signs)
    m["stimuli_configured"] = float(base.config.stimuli)
    env.close()
    return m


def test_a_driver_that_never_brakes_runs_the_brake_test_to_its_end() -> None:
    m = _metrics(seed=3)
    assert m["collisions"] >= 3 and m["collision_resets"] == m["collisions"] and m["resets"] == m["collisions"]
    assert m["reset_time_s"] == pytest.approx(2.0 * m["resets"])  # the time penalty: held 2 s each
    # every brake sign presented and scored, none obeyed (a car held after a reset is no reaction)
    assert m["BrakeSign_n"] + m["BrakeSign_unscored"] == m["signs_in_task"] > 0 and m["BrakeSign_correct"] == 0
    assert m["BrakeSign_misses"] + m["BrakeSign_reset"] == m["BrakeSign_n"]
    # every lead-car brake event presented: all missed, none timed
    assert m["stimuli_presented"] == m["stimuli_configured"] == m["brake_trials"] + m["signs_in_task"]
    assert m["brake_misses"] == m["brake_trials"] > 0 and m["brake_miss_rate"] == 1.0
    assert m["brakeLight_misses"] + m["emergencyBrake_misses"] == m["stimulus_misses"] == m["brake_trials"]
    assert np.isnan(m["brake_rt_mean_s"])
    assert m == _metrics(seed=3)  # deterministic


def test_recover_puts_the_car_back_behind_the_lead_at_rest() -> None:
    env = gym.make(BRAKE, on_collision="recover", reset_hold_s=1.0)
    base: Any = env.unwrapped
    agent = make_agent("rule")
    obs, info = env.reset(seed=3)
    agent.reset(env, 3)
    hit = False
    for _ in range(400):
        a = np.array(agent.act(obs, info), dtype=np.float32)
        a[1] = max(a[1], 0.3)
        obs, _, terminated, _, info = env.step(a)
        assert not terminated
        if hit:
            break
        hit = info["new_collisions"] > 0
    assert hit
    resets = [e for e in info["events"] if e["kind"] == "reset"]
    assert resets and resets[0]["source"] == "collision" and info["resets"] == 1
    assert info["speed_kmh"] < 1.0 and abs(info["lateral_offset_m"]) < 0.05  # at rest in the lane centre, held
    assert 0.0 < base.trace.last("gap_m") < 5.0  # just clear of the lead car, behind it
    env.close()


@pytest.mark.parametrize("env_id", [BRAKE, "OpenDS/ThreeVehiclePlatoon-v0"])
def test_terminate_is_the_default_and_continue_drives_on(env_id: str) -> None:
    env = gym.make(env_id)
    infos, terminated, _ = _never_brakes(env, seed=3, steps=400)
    assert terminated and infos[-1]["collisions"] == 1 and infos[-1]["new_collisions"] == 1
    env.close()
    env = gym.make(env_id, on_collision="continue", end_when_past_lead=False, max_episode_s=40.0)
    infos, terminated, _ = _never_brakes(env, seed=3)
    assert not terminated and infos[-1]["collisions"] >= 1 and infos[-1]["resets"] == 0
    env.close()


def test_platoon_recovers_from_a_collision() -> None:
    env = gym.make("OpenDS/ThreeVehiclePlatoon-v0", on_collision="recover", max_episode_s=60.0)
    infos, terminated, truncated = _never_brakes(env, seed=3)
    assert truncated and not terminated
    m = infos[-1]["episode_metrics"]
    assert m["collisions"] >= 1 and m["collision_resets"] == m["collisions"]
    env.close()


def test_a_traffic_task_recovers_from_running_into_a_car() -> None:
    """OpenDS's motorway task with full gas: the car runs into the traffic ahead."""
    task = str(CORPUS / "opends-cts" / "MotorwayTask")
    env = gym.make("OpenDS/DrivingTask-v0", task=task, on_collision="recover", max_episode_s=25.0)
    infos, terminated, truncated = _never_brakes(env, seed=1, gas=1.0)
    assert truncated and not terminated
    hits = [i for i, info in enumerate(infos) if info["new_collisions"]]
    assert hits and infos[-1]["resets"] == infos[-1]["collisions"] == len(hits)
    assert [e["source"] for e in infos[hits[0] + 1]["events"] if e["kind"] == "reset"] == ["collision"]
    env.close()


def test_bad_mode_and_native_batch_are_refused_clearly() -> None:
    with pytest.raises(ValueError, match="on_collision must be one of terminate, recover, continue"):
        gym.make(BRAKE, on_collision="bounce")
    with pytest.raises(ValueError, match=r"on_collision='recover'.*vectorization_mode='sync'"):
        gym.make_vec(BRAKE, num_envs=2, vectorization_mode="vector_entry_point", on_collision="recover")


def test_studies_recover_from_collisions_by_default(tmp_path: Path) -> None:
    study = load_study(Path(__file__).parents[1] / "configs" / "studies" / "brake.yaml", participants=1)
    assert study.on_collision == "recover"
    assert all(("on_collision", "recover") in t.env_args for t in expand(study))
    text = (Path(__file__).parents[1] / "configs" / "studies" / "brake.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("on_collision: recover", "on_collision: bounce"))
    with pytest.raises(Exception, match=r"bad\.yaml:7: .*on_collision.*must be terminate, recover or continue"):
        load_study(bad)


def _overtaker(env: gym.Env[Any, Any], seed: int, steps: int = 4_000) -> tuple[list[dict[str, Any]], bool]:
    """Full gas, steered to the centre of the other lane (a proportional steering law
    aimed at the free lane): it drives past the lead car (which voids OpenDS's platoon and
    brake tests). Returns infos, terminated."""
    base: Any = env.unwrapped
    env.reset(seed=seed)
    target = base.guide.lane_laterals_m[0]  # the lane beside the platoon's (lane 1)
    infos: list[dict[str, Any]] = []
    terminated = False
    for _ in range(steps):
        lateral = float(base.trace.last("lateral_m"))
        a = np.array([np.clip(0.08 * (target - lateral), -0.1, 0.1), 1.0], dtype=np.float32)
        _, _, terminated, truncated, info = env.step(a)
        infos.append(info)
        if terminated or truncated:
            break
    return infos, terminated


@pytest.mark.parametrize("mode", ["terminate", "recover"])
def test_passing_the_lead_car_ends_the_test_or_puts_the_car_behind_it(mode: str) -> None:
    env = gym.make(BRAKE, on_collision=mode, on_road_exit="recover", max_episode_s=90.0)
    infos, terminated = _overtaker(env, seed=2)
    base: Any = env.unwrapped
    passed = [e for i in infos for e in i["events"] if e["kind"] == "reset" and e["source"] == "passed_lead"]
    if mode == "terminate":
        assert terminated and base._past_lead() and not passed  # OpenDS's rule: overtaking voids the test
    else:
        assert passed, "the car passed the lead car and was put back behind it"
        assert not terminated or base.world.triggers.paused  # never ended by passing the lead
        assert infos[-1]["resets"] >= len(passed)
    env.close()
