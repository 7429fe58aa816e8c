"""Leaving the road: `on_road_exit` terminate | recover | continue, `reset_position()`, and the
exposure every episode reports (distance, stimuli presented, signs reached, off-road time,
resets)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.drivers.rule import RuleDriver

# every env whose car the agent steers (ConTRe's car drives itself along its track)
STEERED = [
    "OpenDS/LaneChangeTest-v0",
    "OpenDS/ThreeVehiclePlatoon-v0",
    "OpenDS/BrakeReaction-v0",
    "OpenDS/ReactionTest-v0",
    "OpenDS/DrivingTask-v0",
]
EXPOSURE = ("distance_m", "stimuli_presented", "off_road_s", "road_exits", "resets", "reset_time_s")


def _left(env: gym.Env) -> np.ndarray:  # type: ignore[type-arg]
    """Steer left with some gas: every steered env leaves its road within seconds."""
    a = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)  # type: ignore[arg-type]
    a[0], a[1] = 0.2, 0.5
    return a


@pytest.mark.parametrize("env_id", STEERED)
def test_terminate_ends_the_episode_on_leaving_the_road(env_id: str) -> None:
    env = gym.make(env_id, max_episode_s=30.0)
    env.reset(seed=1)
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(_left(env))
        if terminated or truncated:
            break
    assert terminated and not truncated
    m = info["episode_metrics"]
    assert m["road_exits"] == 1 and m["resets"] == 0 and m["off_road_s"] > 0
    env.close()


@pytest.mark.parametrize("env_id", STEERED)
def test_recover_puts_the_car_back_in_its_lane_at_rest_and_holds_it(env_id: str) -> None:
    hold_s = 1.5
    env = gym.make(env_id, on_road_exit="recover", reset_hold_s=hold_s, max_episode_s=30.0)
    env.reset(seed=1)
    resets_seen = 0
    after: list[dict] = []  # type: ignore[type-arg]
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(_left(env))
        assert not terminated, "recover must not end the episode on leaving the road"
        if info["resets"] > resets_seen:
            resets_seen = info["resets"]
            ev = [e for e in info["events"] if e["kind"] == "reset"]
            assert ev and ev[0]["source"] == "last_lane_position" and ev[0]["params"]["hold_s"] == hold_s
            after.append(info)
        if truncated:
            break
    assert truncated and resets_seen >= 2
    first = after[0]
    # put back in the centre of a lane, still standing (held by the brake for hold_s)
    assert first["lane_index"] >= 0 and abs(first["lateral_offset_m"]) < 0.05 and first["speed_kmh"] < 0.5
    m = info["episode_metrics"]
    assert m["resets"] == resets_seen and m["reset_time_s"] == pytest.approx(hold_s * resets_seen)
    assert m["road_exits"] >= m["resets"]
    env.close()


def test_recover_holds_the_car_still_for_reset_hold_s() -> None:
    env = gym.make("OpenDS/LaneChangeTest-v0", on_road_exit="recover", reset_hold_s=2.0)
    env.reset(seed=1)
    speeds: list[float] = []
    t_reset = None
    for _ in range(200):
        _, _, _, _, info = env.step(_left(env))
        if t_reset is None and info["resets"]:
            t_reset = next(e for e in info["events"] if e["kind"] == "reset")["t_s"]
        if t_reset is not None:
            speeds.append((info["sim_time_s"] - t_reset, info["speed_kmh"]))  # type: ignore[arg-type]
        if t_reset is not None and info["sim_time_s"] > t_reset + 3.0:
            break
    held = [v for t, v in speeds if t < 1.95]  # type: ignore[misc]
    after = [v for t, v in speeds if t > 2.5]  # type: ignore[misc]
    assert held and max(held) < 0.5, "the car moved while held"
    assert after and max(after) > 5.0, "the car never drove off after the hold"


@pytest.mark.parametrize("env_id", STEERED)
def test_continue_never_resets_and_drives_on_off_the_road(env_id: str) -> None:
    # (the platoon tests also end when the car draws level with the lead car: not here)
    extra = {"end_when_past_lead": False} if "Platoon" in env_id or "Brake" in env_id else {}
    env = gym.make(env_id, on_road_exit="continue", max_episode_s=20.0, **extra)
    env.reset(seed=1)
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(_left(env))
        if terminated or truncated:
            break
    assert truncated and not terminated
    m = info["episode_metrics"]
    assert m["resets"] == 0 and m["road_exits"] >= 1 and m["off_road_s"] > 5.0
    env.close()


def test_reset_position_is_the_same_reset_on_request() -> None:
    env = gym.make("OpenDS/LaneChangeTest-v0")  # terminate: an exit would end it, a requested reset does not
    base = env.unwrapped
    env.reset(seed=1)
    for _ in range(30):
        env.step(np.array([0.0, 1.0], dtype=np.float32))
    before_z = base.world.ego.state.z
    base.reset_position()
    assert base.pending_reset_position
    _, _, terminated, _, info = env.step(np.array([0.0, 1.0], dtype=np.float32))
    assert not terminated and info["resets"] == 1 and not base.pending_reset_position
    assert info["speed_kmh"] < 0.5 and abs(info["lateral_offset_m"]) < 0.05
    assert base.world.ego.state.z >= before_z - 1e-6  # put back where it was in its lane, not ahead
    env.close()


@pytest.mark.parametrize("mode", ["terminate", "recover"])
def test_lct_exposure_counts_signs_reached_and_presented(mode: str) -> None:
    """A driver who drifts off the road after 20 s: with terminate the episode (and the test)
    stops there; with recover the rule driver goes on and reaches every sign."""
    env = gym.make("OpenDS/LaneChangeTest-v0", on_road_exit=mode)
    driver = RuleDriver()
    obs, info = env.reset(seed=3)
    driver.reset(env, 3)
    n_signs = len(env.unwrapped.metric_signs)
    while True:
        t = info["sim_time_s"]
        action = np.array([0.4, 1.0], dtype=np.float32) if 20.0 <= t < 23.0 else driver.act(obs, info)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    m = info["episode_metrics"]
    for key in (*EXPOSURE, "signs_reached"):
        assert key in m
    if mode == "terminate":
        assert m["signs_reached"] < n_signs and m["resets"] == 0
    else:
        assert m["signs_reached"] == n_signs and m["stimuli_presented"] == n_signs and m["resets"] >= 1
        assert m["lane_changes"] == n_signs  # each sign scored once
    assert m["signs_reached"] <= m["stimuli_presented"]
    assert m["distance_m"] > 0.0
    env.close()


@pytest.mark.parametrize(
    ("env_id", "stimuli_key"),
    [
        ("OpenDS/ThreeVehiclePlatoon-v0", "stimuli"),
        ("OpenDS/BrakeReaction-v0", None),
        ("OpenDS/ReactionTest-v0", "reactions"),
        ("OpenDS/ConTRe-v0", "lights"),
    ],
)
def test_exposure_is_reported_by_every_env(env_id: str, stimuli_key: str | None) -> None:
    env = gym.make(env_id, max_episode_s=60.0)
    driver = RuleDriver()
    obs, info = env.reset(seed=2)
    driver.reset(env, 2)
    while True:
        obs, _, terminated, truncated, info = env.step(driver.act(obs, info))
        if terminated or truncated:
            break
    m = info["episode_metrics"]
    assert all(np.isfinite(m[k]) for k in EXPOSURE)
    assert m["stimuli_presented"] >= 1 and m["distance_m"] > 100.0 and m["resets"] == 0
    if stimuli_key is not None:  # the env's own count of what it showed
        assert m["stimuli_presented"] >= m[stimuli_key]
    env.close()


def test_drt_adds_its_stimuli_to_the_exposure() -> None:
    from opends_gym.envs.drt import DetectionResponseTask

    env = DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", max_episode_s=20.0))
    env.reset(seed=1)
    plain = gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", max_episode_s=20.0)
    plain.reset(seed=1)
    a = np.zeros(6, dtype=np.float32)
    a[1] = 1.0
    while True:
        _, _, te, tr, info = env.step(a)
        info2 = plain.step(a)[-1]
        if te or tr:
            break
    m, m2 = info["episode_metrics"], info2["episode_metrics"]
    assert m["drt_stimuli"] >= 3
    assert m["stimuli_presented"] == m2["stimuli_presented"] + m["drt_stimuli"]


def test_bad_mode_and_native_batch_are_refused_clearly() -> None:
    with pytest.raises(ValueError, match="on_road_exit must be one of terminate, recover, continue"):
        gym.make("OpenDS/LaneChangeTest-v0", on_road_exit="stop")
    with pytest.raises(ValueError, match="reset_hold_s must not be negative"):
        gym.make("OpenDS/LaneChangeTest-v0", reset_hold_s=-1.0)
    with pytest.raises(ValueError, match=r"on_road_exit='terminate'.*vectorization_mode='sync'"):
        gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=2, vectorization_mode="vector_entry_point", on_road_exit="recover")


def test_recover_returns_to_the_lane_driven_in_not_one_crossed_on_the_way_off() -> None:
    """Three seconds in the centre lane, then a swerve left across the left lane and off the
    road: the reset puts the car back in the centre lane (the LCT's lane 1), where it left it."""
    env = gym.make("OpenDS/LaneChangeTest-v0", on_road_exit="recover")
    env.reset(seed=1)
    for k in range(200):
        _, _, _, _, info = env.step(np.array([0.0 if k < 30 else 0.3, 1.0], dtype=np.float32))
        if info["resets"]:
            break
    assert info["resets"] == 1 and info["lane_index"] == env.unwrapped.initial_lane == 1
    assert abs(info["lateral_offset_m"]) < 0.05 and info["speed_kmh"] < 0.5
    env.close()


def test_a_recorded_episode_with_resets_replays_exactly(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from opends_gym.record import RecordDrive, read_recording
    from opends_gym.record.replay import replay

    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", on_road_exit="recover", max_episode_s=12.0), tmp_path / "r.mcap")
    env.reset(seed=4)
    while True:
        _, _, terminated, truncated, info = env.step(np.array([0.2, 1.0], dtype=np.float32))
        if terminated or truncated:
            break
    env.close()
    assert info["episode_metrics"]["resets"] >= 2
    marks = [e for e in read_recording(env.paths[-1]).topic("/events") if e["kind"] == "reset"]
    assert len(marks) == info["episode_metrics"]["resets"]
    check = replay(env.paths[-1])
    assert check.ok, check.mismatch
    check.close()
