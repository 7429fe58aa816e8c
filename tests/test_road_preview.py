"""The road preview (`road_preview_m`): the road's heading and the point d m ahead, as a vector
observation option (the far point of Salvucci & Gray's two-point model of steering)."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.envs.observations import EGO_NAMES, VEHICLE_NAMES

from .conftest import DRIVES

LCT = "OpenDS/LaneChangeTest-v0"


def _slots(env: gym.Env, obs: np.ndarray) -> dict[str, float]:
    return dict(zip(env.unwrapped.obs_type.names, obs.tolist(), strict=True))


def test_default_space_unchanged_and_preview_appended() -> None:
    plain = gym.make(LCT)
    k = plain.unwrapped.config.nearby_vehicles
    stimulus = plain.unwrapped.stimulus_names
    names = EGO_NAMES + tuple(f"vehicle{i}_{n}" for i in range(k) for n in VEHICLE_NAMES) + stimulus
    assert plain.unwrapped.obs_type.names == names and plain.observation_space.shape == (len(names),)
    preview = gym.make(LCT, road_preview_m=[10, 50.0])  # a list, as a JSON env spec (Minari's) gives it back
    assert preview.unwrapped.config.road_preview_m == (10.0, 50.0)
    extra = ("road_heading_10m_rad", "road_left_10m_m", "road_heading_50m_rad", "road_left_50m_m")
    assert preview.unwrapped.obs_type.names == names + extra
    a, _ = plain.reset(seed=3)
    b, _ = preview.reset(seed=3)
    np.testing.assert_array_equal(b[: len(names)], a)  # the slots before it keep their values


def test_straight_road_preview_mirrors_heading_error_and_lateral_position() -> None:
    env = gym.make(LCT, road_preview_m=(10.0, 50.0))
    obs, _ = env.reset(seed=0)
    for _ in range(8):  # steer a little (the LCT starts at 60 km/h): the car leaves its lane centre at an angle
        obs, _, terminated, _, _ = env.step(np.array([0.02, 0.6], dtype=np.float32))
        assert not terminated
    v = _slots(env, obs)
    e, lat = v["heading_error_rad"], v["lateral_position_m"]
    assert abs(e) > 0.01 and abs(lat) > 0.01
    for d in (10, 50):  # the road runs straight: its heading is minus the car's error, its line -lat across
        assert v[f"road_heading_{d}m_rad"] == pytest.approx(-e, abs=1e-5)
        assert v[f"road_left_{d}m_m"] == pytest.approx(-d * math.sin(e) - lat * math.cos(e), abs=1e-3)


def test_bending_road_preview_turns_with_the_road() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Countryside task's missing scene meshes
        env = gym.make("OpenDS/DrivingTask-v0", task=str(DRIVES / "Countryside"), road_preview_m=(10.0, 40.0))
        env.reset(seed=0)
    line = env.unwrapped.guide.polyline
    s = np.arange(0.0, line.length - 40.0, 1.0)
    heading = np.array([line.point_at(v)[2] for v in s])
    turn = np.angle(np.exp(1j * (heading[40:] - heading[: len(s) - 40])))  # the road's turn over the next 40 m
    for i in (int(np.argmax(turn)), int(np.argmin(turn))):  # its sharpest left and right bends
        x, z, yaw = line.point_at(float(s[i]))
        obs, _ = env.reset(seed=0, options={"start_pose": {"x": x, "y": 0.0, "z": z, "yaw_rad": yaw}})
        v = _slots(env, obs)
        assert abs(v["heading_error_rad"]) < 1e-3 and abs(v["lateral_position_m"]) < 1e-3  # on the line, along it
        assert v["road_heading_40m_rad"] == pytest.approx(turn[i], abs=1e-3)
        assert abs(turn[i]) > 0.3  # a bend (Countryside's sharpest turn ~ 90 degrees)
        sign = np.sign(turn[i])  # + left: the point ahead lies to the side the road turns to, farther at 40 m
        assert sign * v["road_left_40m_m"] > sign * v["road_left_10m_m"] >= 0.0
        assert sign * v["road_left_40m_m"] < 40.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"road_preview_m": (10.0, -5.0)}, "each distance must be a number in"),
        ({"road_preview_m": ("10",)}, "each distance must be a number in"),
        ({"road_preview_m": (1e4,)}, "each distance must be a number in"),
        ({"road_preview_m": 10.0}, "must be a list of distances"),
        ({"road_preview_m": (10.0, 10.0)}, "distances must differ"),
        ({"road_preview_m": (10.0,), "observation": "topdown"}, "vector observations"),
    ],
)
def test_bad_preview_rejected(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make(LCT, **kwargs)


def test_native_batch_refuses_preview() -> None:
    with pytest.raises(ValueError, match="native batch has no road preview"):
        gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", road_preview_m=(10.0,))
