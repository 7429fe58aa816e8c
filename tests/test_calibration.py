"""The virtual population against the published human values (opends_gym/drivers/literature.csv).

A lean population (10 participants, short tasks) is driven once per task and load; each
asserted literature row must hold: the attentive mean and between-participant SD inside the
published range, each load effect's raw difference and Cohen's d inside its range.
docs/gen_calibration.py runs the same comparison on a bigger population for the docs.
"""

from __future__ import annotations

import math
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401
from opends_gym.drivers.agents import make_agent
from opends_gym.drivers.calibration import RUN_CHECKS as CHECKS
from opends_gym.drivers.calibration import Comparison, effect, level, literature, runs
from opends_gym.drivers.episodes import run_episode
from opends_gym.drivers.participant import ParticipantDriver
from opends_gym.drivers.population import LOADS, POPULATION_SEED, draw_participant, sample_population
from opends_gym.drivers.rule import RuleDriver
from opends_gym.envs.drt import DetectionResponseTask

N = 10


@pytest.fixture(scope="module")
def sim() -> dict[tuple[str, str], list[dict[str, float]]]:
    pop = sample_population(N)
    r = runs(short=True)
    plan = {
        "lct": LOADS,
        "lct_visual_drt": ("baseline", "visual_manual"),
        "brake_expected": ("baseline", "cognitive"),
        "brake_unexpected": ("baseline",),
        "platoon": LOADS,
        "lane_change": ("baseline",),
    }
    return {(name, load): r[name](pop, load, 0) for name, loads in plan.items() for load in loads}


def col(sim: dict[tuple[str, str], list[dict[str, float]]], run: str, load: str, key: str) -> list[float]:
    return [row[key] for row in sim[(run, load)]]


def compare(sim: dict[tuple[str, str], list[dict[str, float]]], key: str) -> Comparison:
    row = literature()[key]
    run, measure, loaded = CHECKS[key]
    base = col(sim, run, "baseline", measure)
    return level(row, base) if loaded is None else effect(row, base, col(sim, run, loaded, measure))


def test_every_literature_row_has_a_source_and_a_check() -> None:
    rows = literature()
    assert set(CHECKS) | {"glance_duration"} == set(rows)
    for row in rows.values():
        assert row.source and row.published and row.verified
        assert row.low <= row.high


@pytest.mark.parametrize("key", [k for k in CHECKS if literature()[k].asserted == "yes"])
def test_population_matches_the_literature(sim: dict[tuple[str, str], list[dict[str, float]]], key: str) -> None:
    c = compare(sim, key)
    r = c.row
    published = f"[{r.low}, {r.high}] (SD [{r.sd_low}, {r.sd_high}], d [{r.d_low}, {r.d_high}])"
    assert c.ok, f"{key}: model {c.value:.3f} (SD {c.sd:.3f}, d {c.d:.2f}) vs published {published}"


def test_glances_only_under_visual_manual_load_and_last_as_published(sim: dict[tuple[str, str], list[dict[str, float]]]) -> None:
    row = literature()["glance_duration"]
    vm = np.array(col(sim, "lct", "visual_manual", "glance_s"))
    assert row.low <= float(np.nanmean(vm)) <= row.high
    # cognitive load concentrates the gaze: shorter scanning glances only, and fewer of them
    assert np.nanmean(col(sim, "lct", "cognitive", "glance_s")) < row.low


def test_cognitive_effect_on_mdev_is_smaller_than_the_visual_manual_one(sim: dict[tuple[str, str], list[dict[str, float]]]) -> None:
    assert compare(sim, "mdev_cognitive").value < compare(sim, "mdev_visual_manual").value


def test_lane_change_starts_after_the_sign_is_read_and_a_lane_chosen(sim: dict[tuple[str, str], list[dict[str, float]]]) -> None:
    # reading the roadside sign and choosing among three lanes take longer than a simple
    # response to a tactile DRT stimulus, for every participant
    onset = col(sim, "lct", "baseline", "iso_mean_latency_s")
    drt = col(sim, "lct", "baseline", "drt_mean_rt_s")
    assert all(o > d + 0.3 for o, d in zip(onset, drt, strict=True))


def test_a_load_acts_only_through_its_mechanism() -> None:
    # with common noise, a cognitive task that never holds the channel leaves the drive
    # exactly as at baseline; without it each load's drive has its own noise
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", signs=2))
    idle = replace(draw_participant(4), cog_busy=0.0)
    base = run_episode(env, ParticipantDriver(None, idle, "baseline", common_noise=True), 1).metrics
    cog = run_episode(env, ParticipantDriver(None, idle, "cognitive", common_noise=True), 1).metrics
    assert base["mdev_basic_m"] == cog["mdev_basic_m"] and base["drt_mean_rt_s"] == cog["drt_mean_rt_s"]
    busy = run_episode(env, ParticipantDriver(None, draw_participant(4), "cognitive", common_noise=True), 1).metrics
    assert busy["drt_mean_rt_s"] != base["drt_mean_rt_s"]
    own = run_episode(env, ParticipantDriver(None, idle, "cognitive"), 1).metrics
    assert own["mdev_basic_m"] != base["mdev_basic_m"]


def test_participants_differ_and_are_reproducible() -> None:
    a, b = sample_population(5), sample_population(5)
    assert a == b
    assert draw_participant(3) == sample_population(8)[3]
    assert len({p.select_s for p in a}) == 5
    assert sample_population(3, seed=1) != sample_population(3, seed=2)


def test_participant_spec_drives_like_the_agent_interface() -> None:
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", signs=2))
    agent = make_agent("participant:7:cognitive")
    assert isinstance(agent, ParticipantDriver) and agent.params == draw_participant(7, POPULATION_SEED) and agent.load == "cognitive"
    first = run_episode(env, agent, 3).metrics
    again = run_episode(env, make_agent("participant:7:cognitive"), 3).metrics
    assert first["drt_mean_rt_s"] == again["drt_mean_rt_s"] and first["mdev_basic_m"] == again["mdev_basic_m"]
    with pytest.raises(ValueError, match="unknown load"):
        make_agent("participant:1:sleepy")
    with pytest.raises(ValueError, match="participant number"):
        make_agent("participant:x")


def test_driver_constructed_on_an_env_acts_and_lists_glances() -> None:
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", signs=2))
    obs, _ = env.reset(seed=0)
    driver = ParticipantDriver(env, draw_participant(2), "visual_manual", seed=0)
    for _ in range(400):
        obs, _, term, trunc, _ = env.step(driver.act(obs))
        if term or trunc:
            break
    assert driver.glances and all(0.0 <= s < e for s, e in driver.glances)
    driver.reset(0)
    assert driver.glances == []


def test_rule_driver_never_presses_a_drt_button_within_100_ms() -> None:
    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", signs=3))
    m = run_episode(env, RuleDriver(), 0).metrics
    drt = env
    rts = [r - max(o for o in drt.onsets if o <= r) for r in drt.responses]
    assert m["drt_premature"] == 0 and m["drt_hit_rate"] == 1.0
    assert min(rts) >= 0.1 and math.isfinite(m["drt_mean_rt_s"])
