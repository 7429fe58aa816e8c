"""Recordings Foxglove shows as a drive: the road and its lane lines as a SceneUpdate,
FrameTransforms for the ego and traffic, the driver's view as CompressedImages; replay
still exact (it ignores these topics)."""

from __future__ import annotations

import base64
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pygame
import pytest
from mcap.reader import make_reader

import opends_gym  # noqa: F401
from opends_gym.record import RecordDrive, read_recording
from opends_gym.record.replay import replay
from tests.conftest import DRIVES

ROOT = Path(__file__).resolve().parent.parent


def _schemas(path: Path) -> dict[str, str]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {ch.topic: summary.schemas[ch.schema_id].name for ch in summary.channels.values()}


def _record(tmp_path: Path, env_id: str, steps: int, action: object, **options: object) -> Path:
    env = RecordDrive(gym.make(env_id, render_width=160, render_height=90), tmp_path / "drive.mcap", **options)  # type: ignore[arg-type]
    env.reset(seed=1)
    for _ in range(steps):
        env.step(action)
    env.close()
    return env.paths[-1]


@pytest.fixture(scope="module")
def lct_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _record(
        tmp_path_factory.mktemp("lct"), "OpenDS/LaneChangeTest-v0", 25, np.array([0.01, 1.0], dtype=np.float32), video_rate_hz=4.0
    )


def test_the_road_and_its_lane_lines_are_a_scene_update(lct_recording: Path) -> None:
    rec = read_recording(lct_recording)
    assert _schemas(lct_recording)["/foxglove/road"] == "foxglove.SceneUpdate"
    (update,) = rec.topic("/foxglove/road")  # once per file
    entities = {e["id"]: e for e in update["entities"]}
    lines = entities["road/lane_lines"]["lines"][0]
    assert lines["type"] == 2 and entities["road/lane_lines"]["frame_id"] == "world"  # a line list in the Z-up world frame
    pts = lines["points"]
    # OpenDS X bands -> Foxglove y = -X: one straight line along the road per lane edge
    env = gym.make("OpenDS/LaneChangeTest-v0")
    edges = sorted({round(-v, 6) for b in env.unwrapped.world.road.lanes for v in (b.x_min, b.x_max)})
    assert sorted({round(p["y"], 6) for p in pts}) == edges == pytest.approx([-5.775, -1.925, 1.925, 5.775])
    start_x = -env.unwrapped.world.task.start_pose.position_m[2]
    end_x = -min(o.position[2] for o in env.unwrapped.world.objects.objects)
    xs = [p["x"] for p in pts]
    assert min(xs) < start_x and max(xs) > end_x  # from behind the start to beyond the last object (the end trigger)
    tri = entities["road/surface"]["triangles"][0]["points"]
    assert len(tri) % 3 == 0 and {round(p["y"], 6) for p in tri} == {edges[0], edges[-1]}  # the surface spans edge to edge
    env.close()


def test_frame_transforms_follow_the_recorded_pose(lct_recording: Path) -> None:
    rec = read_recording(lct_recording)
    assert _schemas(lct_recording)["/tf"] == "foxglove.FrameTransforms"
    ego = rec.topic("/ego")
    tf = rec.topic("/tf")
    assert len(tf) == len(ego) > 100
    for e, t in zip(ego, tf, strict=True):
        (ego_tf,) = [x for x in t["transforms"] if x["child_frame_id"] == "ego"]
        assert ego_tf["parent_frame_id"] == "world"
        tr = ego_tf["translation"]
        assert (tr["x"], tr["y"], tr["z"]) == (-e["z_m"], -e["x_m"], e["y_m"])
        assert ego_tf["rotation"]["z"] == pytest.approx(math.sin(e["yaw_rad"] / 2))
        assert ego_tf["timestamp"]["sec"] + ego_tf["timestamp"]["nsec"] / 1e9 == pytest.approx(e["t_s"])


def test_traffic_cars_get_their_own_frames(tmp_path: Path) -> None:
    path = _record(tmp_path, "OpenDS/ThreeVehiclePlatoon-v0", 5, np.array([0, 0.5, -1, -1, -1, -1], dtype=np.float32))
    rec = read_recording(path)
    last_tf, last_traffic = rec.topic("/tf")[-1], rec.topic("/traffic")[-1]
    frames = {x["child_frame_id"]: x["translation"] for x in last_tf["transforms"]}
    assert set(frames) == {"ego"} | {f"vehicle_{i}" for i in range(len(last_traffic["vehicles"]))} and len(frames) == 3
    for i, v in enumerate(last_traffic["vehicles"]):
        assert frames[f"vehicle_{i}"] == {"x": -v["z_m"], "y": -v["x_m"], "z": v["y_m"]}


@pytest.mark.parametrize("fmt", ["png", "jpeg"])
def test_the_driver_view_is_recorded_as_compressed_images_at_the_asked_rate(tmp_path: Path, fmt: str) -> None:
    path = _record(tmp_path, "OpenDS/LaneChangeTest-v0", 20, np.array([0.0, 1.0], dtype=np.float32), video_rate_hz=5.0, video_format=fmt)
    rec = read_recording(path)
    assert _schemas(path)["/foxglove/driver_view"] == "foxglove.CompressedImage"
    images = rec.topic("/foxglove/driver_view")
    assert len(images) == 10  # 2 simulated seconds at 5 Hz
    times = [m["timestamp"]["sec"] + m["timestamp"]["nsec"] / 1e9 for m in images]
    assert np.allclose(np.diff(times), 0.2)
    for m in images[:2]:
        assert m["format"] == fmt
        img = pygame.image.load(io.BytesIO(base64.b64decode(m["data"])), f"view.{'jpg' if fmt == 'jpeg' else 'png'}")
        assert img.get_size() == (160, 90)
    # the view shows a road, not a blank frame
    pixels = pygame.surfarray.array3d(img)
    assert pixels.std() > 10.0


def test_no_video_unless_asked_and_replay_ignores_the_new_topics(lct_recording: Path, tmp_path: Path) -> None:
    plain = read_recording(_record(tmp_path, "OpenDS/LaneChangeTest-v0", 3, np.array([0.0, 1.0], dtype=np.float32)))
    assert plain.topic("/foxglove/driver_view") == [] and plain.topic("/tf")
    check = replay(lct_recording)
    assert check.ok, check.mismatch
    check.close()


def test_a_route_road_has_lines_at_its_lane_edges(tmp_path: Path) -> None:
    """Countryside: a traffic route, not X bands: every lane-line point lies at a lane edge
    across the route (the guide's lateral position)."""
    env = RecordDrive(gym.make("OpenDS/DrivingTask-v0", task=str(DRIVES / "Countryside")), tmp_path / "c.mcap")
    env.reset(seed=0)
    env.step(np.array([0.0, 0.0], dtype=np.float32))
    guide = env.unwrapped.guide
    env.close()
    (update,) = read_recording(env.paths[-1]).topic("/foxglove/road")
    pts = next(e for e in update["entities"] if e["id"] == "road/lane_lines")["lines"][0]["points"]
    half = guide.lane_width_m / 2
    expected = sorted({round(c + d, 3) for c in guide.lane_laterals_m for d in (-half, half)})
    sample = pts[:: max(1, len(pts) // 50)]
    for p in sample:
        lat = guide.locate(-p["y"], -p["x"]).lateral_m  # back to OpenDS x = -y, z = -x
        assert min(abs(lat - e) for e in expected) < 0.3, (p, lat, expected)


def test_cli_record_video(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    cmd = [sys.executable, "-m", "opends_gym.cli.main", "run", "LaneChangeTest", "--agent", "rule", "--max-seconds", "1"]
    done = subprocess.run(
        [*cmd, "--record", str(out), "--record-video", "2", "--json"], capture_output=True, text=True, cwd=ROOT, check=False
    )
    assert done.returncode == 0, done.stderr
    assert len(read_recording(json.loads(done.stdout)["episodes"][0]["recording"]).topic("/foxglove/driver_view")) == 2
    bad = subprocess.run([*cmd, "--record-video"], capture_output=True, text=True, cwd=ROOT, check=False)
    assert bad.returncode != 0 and "--record-video needs --record" in bad.stderr
