"""Drive recording to MCAP and exact replay, through the public interface.

Record short drives of two envs on both physics backends and replay them with the check;
tamper with one float and see the check fail; follow mode (startRecording/stopRecording)
with OpenDS's file names; never overwriting; World-level (human-style) recordings replayed
from /controls; a file cut short reads back as a prefix and still replays; the CLI.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.cli.main import main
from opends_gym.record import DriveRecorder, RecordDrive, attach_recorder, read_recording
from opends_gym.record.analyze import analyze
from opends_gym.record.drive import load_drive
from opends_gym.record.replay import ReplayError, replay, replay_to
from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World


def drive(env: gym.Env, seed: int, steps: int | None = None, buttons: bool = False, steer: float = 0.04) -> int:
    """A seeded, gentle random driver; returns the steps taken."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    n = 0
    while steps is None or n < steps:
        a = [rng.uniform(-steer, steer), rng.uniform(-0.3, 1.0)]
        if buttons:
            a += [float(rng.uniform(-1, 1) > 0.8), 0.0, 0.0, 0.0]
        _, _, terminated, truncated, _ = env.step(np.asarray(a, dtype=np.float32))
        n += 1
        if terminated or truncated:
            break
    return n


@pytest.mark.parametrize("physics", ["fast", "bullet"])
@pytest.mark.parametrize("env_id", ["OpenDS/LaneChangeTest-v0", "OpenDS/ReactionTest-v0"])
def test_record_then_replay_check_is_exact(tmp_path: Path, env_id: str, physics: str) -> None:
    kwargs: dict[str, Any] = {"max_episode_s": 12.0, "physics": physics}
    if env_id.endswith("ReactionTest-v0"):
        kwargs["action"] = "continuous_buttons"  # keys and buttons go through the recording too
    env = RecordDrive(gym.make(env_id, **kwargs), tmp_path / "drive.mcap")
    steps = drive(env, seed=7, buttons="action" in kwargs)
    env.close()
    assert env.paths == [tmp_path / "drive.mcap"]
    rec = read_recording(env.paths[0])
    assert rec.complete and rec.meta["env_id"] == env_id and rec.meta["seed"] == 7
    assert rec.meta["env_kwargs"]["physics"] == physics
    assert len(rec.topic("/actions")) == steps
    assert len(rec.topic("/ego")) == len(rec.topic("/controls")) == steps * 6  # 60 Hz physics, 10 Hz policy
    assert rec.topic("/events"), "the task's triggers fired"
    assert {"/foxglove/ego_pose", "/foxglove/scene"} <= set(rec.messages)
    result = replay(env.paths[0])
    result.close()
    assert result.ok, str(result.mismatch)
    assert result.checked["/ego"] == steps * 6 and result.checked["/events"] == len(rec.topic("/events"))


def test_replay_check_finds_a_one_ulp_difference(tmp_path: Path) -> None:
    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", max_episode_s=5.0), tmp_path / "d.mcap")
    drive(env, seed=3)
    env.close()
    rec = read_recording(env.paths[0])
    _, msg = rec.messages["/ego"][100]
    msg["speed_mps"] = float(np.nextafter(msg["speed_mps"], np.inf))
    result = replay(rec)
    assert not result.ok
    m = result.mismatch
    assert m is not None and (m.topic, m.index, m.field) == ("/ego", 100, "speed_mps")
    assert m.recorded != m.replayed and abs(m.recorded - m.replayed) < 1e-9


def test_recording_content_units_and_foxglove_frame(tmp_path: Path) -> None:
    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", max_episode_s=3.0), tmp_path / "d.mcap", rate_hz=20.0)
    drive(env, seed=1)
    env.close()
    rec = read_recording(env.paths[0])
    assert rec.meta["ego_rate_hz"] == pytest.approx(20.0) and rec.meta["physics_hz"] == pytest.approx(60.0)
    ego = rec.topic("/ego")
    assert len(ego) == 3 * 20 and len(rec.topic("/controls")) == 3 * 60
    e = ego[-1]
    assert e["speed_kmh"] == pytest.approx(e["speed_mps"] * 3.6)
    assert e["lane"] in ("0", "1", "2") and e["gear"] >= 1 and e["rpm"] > 0 and e["fuel_used_l"] > 0
    assert e["headway_s"] is None  # no lead vehicle: null, not inf
    pose = rec.topic("/foxglove/ego_pose")[-1]
    assert pose["frame_id"] == "world"
    assert pose["pose"]["position"] == {"x": -e["z_m"], "y": -e["x_m"], "z": e["y_m"]}
    t_ns = rec.messages["/ego"][-1][0]
    assert t_ns == round(e["t_s"] * 1e9) and t_ns == pose["timestamp"]["sec"] * 10**9 + pose["timestamp"]["nsec"]
    assert rec.meta["task_hash_of"] == "content" and len(rec.meta["task_sha256"]) == 64
    assert rec.meta["analysis_lct"]["signs"] and rec.meta["software_version"].startswith("opends_gym")


def test_episode_files_never_overwrite(tmp_path: Path) -> None:
    old = tmp_path / "drive.mcap"
    old.write_bytes(b"an older recording")
    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", max_episode_s=1.0), old)
    for seed in (1, 2):
        drive(env, seed)
    drive(env, seed=None)  # type: ignore[arg-type]  # the wrapper draws a seed
    env.close()
    assert old.read_bytes() == b"an older recording"
    assert [p.name for p in env.paths] == ["drive(2).mcap", "drive(3).mcap", "drive(4).mcap"]
    seeds = [read_recording(p).meta["seed"] for p in env.paths]
    assert seeds[:2] == [1, 2] and isinstance(seeds[2], int)
    assert replay(env.paths[2]).ok


def test_follow_mode_records_between_start_and_stop_recording(tmp_path: Path) -> None:
    # a short LCT: the start trigger runs startRecording track=1, the end trigger stopRecording
    env_kwargs: dict[str, Any] = {"signs": 2, "lead_in_m": 60.0, "lead_out_m": 60.0, "max_episode_s": 60.0}
    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", **env_kwargs), tmp_path / "carData.mcap", follow_recording_actions=True)
    for _ in range(2):
        drive(env, seed=4, steer=0.0)  # straight down the track to the end trigger
    env.close()
    assert [p.name for p in env.paths] == ["carData_track1.mcap", "carData_track1(2).mcap"]
    rec = read_recording(env.paths[0])
    assert rec.complete and rec.meta["mode"] == "follow" and rec.meta["track"] == 1
    kinds = [(e["kind"], e["params"].get("op")) for e in rec.topic("/events")]
    assert kinds.index(("recording", "start")) < kinds.index(("recording", "stop"))
    stop_t = rec.topic("/events")[kinds.index(("recording", "stop"))]["t_s"]
    assert rec.topic("/events")[-1]["t_s"] == stop_t, "the file ends with the step of stopRecording"
    assert rec.topic("/ego")[-1]["t_s"] < stop_t
    ego = rec.topic("/ego")
    assert ego[0]["t_s"] > 0.0 and all(e["recording"] for e in ego)
    assert rec.topic("/controls")[0]["step"] == 1  # the inputs since the reset come first
    result = replay(env.paths[1])
    assert result.ok, str(result.mismatch)


def test_world_level_recording_replays_from_controls(tmp_path: Path) -> None:
    world = World("ReactionTest", seed=11)
    rec_ = attach_recorder(world, tmp_path / "human.mcap", seed=11, meta={"driver": "P07"})
    for k in range(300):
        keys = ("KEY_RETURN",) if k == 100 else ()
        world.step(DriverControls(steering=0.01 * np.sin(k / 20), accelerator=0.8, brake=0.2 if 150 < k < 170 else 0.0, keys=keys))
    world.step(DriverControls(steering=float("nan"), accelerator=2.0))  # sanitised inputs are what is recorded
    rec_.close()
    assert world.observers == []
    rec = read_recording(rec_.path)  # type: ignore[arg-type]
    assert rec.meta["driver"] == "P07" and rec.meta.get("env_id") is None and rec.meta["task_hash_of"] == "files"
    assert rec.topic("/controls")[100]["keys"] == ["KEY_RETURN"]
    assert rec.topic("/controls")[-1]["steering"] == 0.0 and rec.topic("/controls")[-1]["accelerator"] == 1.0
    result = replay(rec)
    assert result.ok, str(result.mismatch)
    assert result.inputs_fed == 301 and result.checked["/ego"] == 301


def test_recorder_attached_mid_drive_is_marked_not_replayable(tmp_path: Path) -> None:
    world = World("ReactionTest", seed=1)
    world.run(1.0, DriverControls(accelerator=1.0))
    with DriveRecorder(world, tmp_path / "late.mcap") as r:
        world.run(0.5, DriverControls(accelerator=1.0))
    rec = read_recording(r.path)  # type: ignore[arg-type]
    assert rec.meta["replayable"] is False and len(rec.topic("/ego")) == 30
    with pytest.raises(ReplayError, match="not replayable"):
        replay(rec)


def test_cut_short_file_reads_back_as_a_prefix_and_replays(tmp_path: Path) -> None:
    env = RecordDrive(gym.make("OpenDS/LaneChangeTest-v0", max_episode_s=8.0), tmp_path / "full.mcap", flush_interval_s=0.5)
    drive(env, seed=2)
    env.close()
    full = read_recording(env.paths[0])
    data = env.paths[0].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    part = read_recording(cut)
    assert not part.complete and part.problem
    n = len(part.topic("/ego"))
    assert 0 < n < len(full.topic("/ego"))
    assert part.topic("/ego") == full.topic("/ego")[:n]
    result = replay(part)
    assert result.ok, str(result.mismatch)
    assert result.checked["/ego"] == n
    d = load_drive(cut)  # the analyzer reads it too, and says so
    assert not d.complete and d.n == n and "cut short" in d.notes[0]
    assert analyze(d).summary["duration_s"] == pytest.approx(d.col("t_s")[-1] - d.col("t_s")[0])


def test_not_an_mcap_file_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "x.mcap"
    bad.write_text("hello")
    with pytest.raises(ValueError, match="not an MCAP recording"):
        read_recording(bad)


def test_record_drive_refuses_action_wrappers(tmp_path: Path) -> None:
    lo, hi = np.full(2, -0.5, dtype=np.float32), np.full(2, 0.5, dtype=np.float32)
    env = gym.wrappers.RescaleAction(gym.make("OpenDS/LaneChangeTest-v0"), lo, hi)
    with pytest.raises(ValueError, match="below action wrappers"):
        RecordDrive(env, tmp_path / "d.mcap")


def test_cli_run_record_then_replay_check_and_at(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "drive.mcap"
    assert main(["run", "OpenDS/LaneChangeTest-v0", "--agent", "constant:0.01,1", "--max-seconds", "6", "--record", str(path)]) == 0
    assert f"recorded episode 0: {path}" in capsys.readouterr().out
    assert main(["replay", str(path), "--check"]) == 0
    assert "check: EXACT" in capsys.readouterr().out
    assert main(["replay", str(path), "--at", "2.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["exact"] and out["state"]["t_s"] == pytest.approx(2.5) and out["state"]["step"] == 150
    at = replay_to(path, 2.5)
    full = read_recording(path)
    ego_then = next(e for e in full.topic("/ego") if e["step"] == 150)
    assert at.world.step_count == 150 and at.world.ego.state.z == ego_then["z_m"] and at.env is not None
    at.close()
    assert main(["replay", str(tmp_path / "missing.mcap")]) == 2
