"""Drives as data: Minari export round trip, behaviour cloning, a drive against a population."""

from __future__ import annotations

import contextlib
import csv
import io
import json
from pathlib import Path

import minari
import numpy as np
import pytest

from opends_gym.cli.main import main

from .conftest import DRIVES, cli_output

ROOT = Path(__file__).resolve().parents[1]
COUNTRYSIDE = DRIVES / "Countryside"
SHORT_LOG = DRIVES / "drives" / "2019_01_04-11_26_07" / "carData(3).txt"


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """A 6 s LCT run of the rule driver, recorded, with the metrics `run` printed."""
    d = tmp_path_factory.mktemp("rec")
    out = d / "run.json"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["run", "--agent", "rule", "--max-seconds", "6", "--seed", "3", "--record", str(d / "lct.mcap"), "--json"]) == 0
    out.write_text(buf.getvalue())
    return d / "lct.mcap", json.loads(buf.getvalue())["episodes"][0]


@pytest.fixture
def minari_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    return tmp_path / "minari"


def test_minari_round_trip_gives_back_the_env_and_the_drive(recording: tuple[Path, dict], minari_dir: Path) -> None:
    path, run = recording
    code, out, err = _main_output(["export", str(path), "--minari", "test/lct"])
    assert code == 0
    assert "test/lct-v0: 1 episodes, 60 steps" in out
    ds = minari.load_dataset("test/lct-v0")
    ep = ds[0]
    assert ep.actions.shape == (60, 2) and ep.observations.shape[0] == 61
    assert ep.truncations[-1] and not ep.terminations.any()
    assert len(ep.infos["speed_kmh"]) == 61
    meta = next(iter(ds.storage.get_episode_metadata([0])))
    assert meta["metric/sdlp_m"] == pytest.approx(run["sdlp_m"])
    # the recovered env is ours and drives the dataset's actions to the dataset's observations and rewards
    env = ds.recover_environment()
    assert env.spec.id == "OpenDS/LaneChangeTest-v0"
    obs, _ = env.reset(seed=3)
    assert np.array_equal(obs, ep.observations[0])
    for k, a in enumerate(ep.actions):
        obs, reward, *_ = env.step(a)
        assert np.array_equal(obs, ep.observations[k + 1]) and reward == pytest.approx(ep.rewards[k])
    env.close()
    # the name is taken now: a second export says so in one line
    code, out, err = _main_output(["export", str(path), "--minari", "test/lct"])
    assert code == 2
    assert "exists already" in err


def test_cardata_log_becomes_held_actions_at_the_policy_rate(minari_dir: Path) -> None:
    from opends_gym.data.episodes import load_episode
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.record.conform import Recorded

    ep = load_episode(SHORT_LOG, None, str(COUNTRYSIDE))
    rec = Recorded(SHORT_LOG)
    assert ep.kind == "cardata" and ep.env_spec.id == "OpenDS/DrivingTask-v0"
    for k, a in enumerate(ep.actions):  # the input held at the start of each 0.1 s step
        row = int(np.searchsorted(rec.sim_t - rec.sim_t[0], k / 10 + 1e-9, side="right")) - 1
        assert a[0] == pytest.approx(rec.steering[row])
        assert a[1] == pytest.approx(-rec.brake[row] if rec.brake[row] > 0 else rec.gas[row])
    trimmed = load_episode(SHORT_LOG, None, str(COUNTRYSIDE), trim_idle=True)  # from the first gas
    assert trimmed.actions[0][1] > 0 and trimmed.steps < ep.steps
    ds = write_dataset("test/cs", [ep])
    assert ds.total_steps == ep.steps
    assert minari.load_dataset("test/cs-v0").recover_environment().spec.kwargs["task"] == str(COUNTRYSIDE.resolve())


def test_behaviour_clone_learns_the_actions_and_drives_as_an_agent(minari_dir: Path, tmp_path: Path) -> None:
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent

    env = make_env("OpenDS/LaneChangeTest-v0", {"max_episode_s": 3.0})
    ds = write_dataset("test/bc", [collect(env, make_agent("constant:0.02,0.7"), seed) for seed in (0, 1)])
    folder = tmp_path / "clone"
    options = ["--epochs", "300", "--history", "3", "--validation", "0"]
    code, out, _ = _main_output(["train", "bc", "test/bc-v0", "--out", str(folder), *options])
    assert code == 0
    assert json.loads(out)["steps"] == ds.total_steps
    clone = make_agent(f"bc:{folder}")
    obs, info = env.reset(seed=7)  # a new episode: the clone acts as the driver it was cloned from
    clone.reset(env, 7)
    for _ in range(10):
        action = clone.act(obs, info)
        assert action == pytest.approx([0.02, 0.7], abs=0.1)
        obs, _, _, _, info = env.step(action)
    env.close()
    # the clone is an agent like any other
    code, out, _ = _main_output(["run", "--agent", f"bc:{folder}", "--max-seconds", "1", "--json"])
    assert code == 0
    assert json.loads(out)["episodes"][0]["steps"] == 10


def test_clone_with_history_and_actions_sees_at_run_time_what_it_was_trained_on(minari_dir: Path, tmp_path: Path) -> None:
    """--history N --actions: the network's input at run time is the training input built from
    the episode the clone drove (drivers.bc.stacked_inputs); one of three episodes is held out."""
    import torch

    from opends_gym.data.episodes import collect, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent
    from opends_gym.drivers.bc import CLIP, action_output, stacked_inputs

    env = make_env("OpenDS/LaneChangeTest-v0", {"max_episode_s": 2.0})
    eps = [collect(env, make_agent("constant:-0.03,0.6"), seed) for seed in (0, 1, 2)]
    write_dataset("test/bca", eps)
    folder = tmp_path / "clone"
    options = ["--epochs", "300", "--history", "4", "--actions", "--validation", "0.3", "--patience", "300"]
    code, out, _ = _main_output(["train", "bc", "test/bca-v0", "--out", str(folder), *options])
    assert code == 0
    summary = json.loads(out)
    assert summary["held_out_episodes"] == 1 and summary["steps"] == 2 * eps[0].steps, summary
    assert 1 <= summary["best_epoch"] <= 300
    clone = make_agent(f"bc:{folder}")
    driven = collect(env, clone, 9)
    env.close()
    assert np.asarray(driven.actions) == pytest.approx(np.tile([-0.03, 0.6], (driven.steps, 1)), abs=0.1)
    s = json.loads((folder / "bc.json").read_text())
    assert s["history"] == 4 and s["actions"] is True
    obs, act = np.asarray(driven.observations[:-1], np.float32), np.asarray(driven.actions, np.float32)
    x = np.clip((stacked_inputs(obs, act, 4, True) - np.asarray(s["obs_mean"])) / np.asarray(s["obs_std"]), -CLIP, CLIP)
    with torch.no_grad():
        y = clone.net(torch.from_numpy(x.astype(np.float32))).numpy()
    assert action_output(y, s) == pytest.approx(act, abs=1e-5)


def test_train_bc_without_a_dataset_is_one_line() -> None:
    code, _, err = _main_output(["train", "bc"])
    assert code == 2
    assert "bc needs a dataset" in err


def test_percentile_rank_is_scipys_mean_kind() -> None:
    from scipy.stats import percentileofscore

    from opends_gym.data.against import percentile_rank

    pop = [0.1, 0.2, 0.2, 0.3, 0.5]
    for v in (0.05, 0.2, 0.25, 0.5, 0.9):
        assert percentile_rank(v, pop) == pytest.approx(percentileofscore(pop, v, kind="mean"))


def test_analyze_against_a_study_table(recording: tuple[Path, dict], tmp_path: Path) -> None:
    path, run = recording
    table = tmp_path / "table.csv"
    sdlp = run["sdlp_m"]
    values = [sdlp * f for f in (0.5, 0.8, 1.2, 1.5)]  # two virtual participants below the drive, two above
    with table.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["participant", "source", "condition", "task", "trial", "metric", "value"])
        for i, v in enumerate(values):
            w.writerow([f"v{i}", "virtual", "baseline", "lct", 0, "sdlp_m", v])
            w.writerow([f"v{i}", "virtual", "cognitive", "lct", 0, "sdlp_m", 10 * v])
        w.writerow(["h0", "human", "baseline", "lct", 0, "sdlp_m", 0.0])  # people are not the reference
    code, out, err = _main_output(["analyze", str(path), "--against", str(table), "--json"])
    assert code == 0
    against = json.loads(out)["against"]
    assert "condition baseline" in against["reference"]
    row = against["metrics"]["sdlp_m"]
    assert row["percentile"] == pytest.approx(50.0) and row["n"] == 4
    code, out, err = _main_output(["analyze", str(path), "--against", str(table), "--condition", "cognitive"])
    assert code == 0
    line = next(x for x in out.splitlines() if x.strip().startswith("sdlp_m") and "%" not in x and len(x.split()) == 5)
    assert line.split()[2] == "0"  # below every participant under load
    code, out, err = _main_output(["analyze", str(path), "--against", str(table), "--condition", "visual"])
    assert code == 2
    assert "--condition" in err


def _main_output(argv: list[str]) -> tuple[int, str, str]:
    """`opends-gym ARGV` in its own process (conftest.cli_output)."""
    return cli_output(argv)


def test_population_spec_errors_are_one_line(recording: tuple[Path, dict]) -> None:
    path, _ = recording
    code, _, err = _main_output(["analyze", str(path), "--against", "population:x"])
    assert code == 2
    assert "population:N[:LOAD]" in err and len(err.strip().splitlines()) == 1


def test_analyze_against_a_simulated_population(recording: tuple[Path, dict]) -> None:
    from opends_gym.data.against import percentile_rank
    from opends_gym.data.episodes import make_env
    from opends_gym.drivers.agents import make_agent
    from opends_gym.drivers.episodes import run_episode

    path, run = recording
    code, out, _ = _main_output(["analyze", str(path), "--against", "population:2", "--json"])
    assert code == 0
    against = json.loads(out)["against"]
    assert against["reference"] == "2 virtual participants (baseline) on OpenDS/LaneChangeTest-v0"
    row = against["metrics"]["sdlp_m"]
    assert row["value"] == pytest.approx(run["sdlp_m"]) and row["n"] == 2
    # the same participants on the recording's env (its 6 s limit), seeded by their number
    env = make_env("OpenDS/LaneChangeTest-v0", {"max_episode_s": 6.0})
    pop = [run_episode(env, make_agent(f"participant:{i}"), i).metrics["sdlp_m"] for i in range(2)]
    env.close()
    assert row["percentile"] == pytest.approx(percentile_rank(run["sdlp_m"], pop))


MID_ROAD_LOG = DRIVES / "drives" / "2019_01_04-11_40_24" / "carData.txt"  # starts ~300 m from the task's start


def test_cardata_log_is_redriven_from_its_own_first_pose(minari_dir: Path) -> None:
    from opends_gym.data.episodes import cardata_start_pose, load_episode, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.errors import UserError
    from opends_gym.record.conform import GOALS, Recorded

    rec = Recorded(MID_ROAD_LOG)
    ep = load_episode(MID_ROAD_LOG, None, str(COUNTRYSIDE))
    env = make_env(ep.env_spec.id, dict(ep.env_spec.kwargs))
    obs, info = env.reset(options={"start_pose": cardata_start_pose(rec, 0)})
    s = env.unwrapped.world.ego.state
    assert (s.x, s.y, s.z, s.yaw) == pytest.approx((rec.x[0], rec.y[0], rec.z[0], rec.yaw[0]), abs=1e-6)
    assert np.array_equal(obs, ep.observations[0])  # the export started there too
    assert info["speed_kmh"] == pytest.approx(rec.speed_kmh[0], abs=1e-6)
    meta = next(iter(write_dataset("test/mid", [ep]).storage.get_episode_metadata([0])))
    assert meta["start_pose/x"] == pytest.approx(rec.x[0]) and meta["start_pose/yaw_rad"] == pytest.approx(rec.yaw[0])
    # the log's actions from its own pose follow its path: within the conformance position goal
    # over a 5 s window, and on the road for 10 s (from the task's start they left it after 5.5 s)
    t0 = rec.sim_t[0]
    for k, a in enumerate(ep.actions[:100]):
        _, _, terminated, _, info = env.step(a)
        assert not terminated and info["lane_index"] >= 0
        if k < 50:
            t = t0 + (k + 1) / 10
            err = np.hypot(s.x - np.interp(t, rec.sim_t, rec.x), s.z - np.interp(t, rec.sim_t, rec.z))
            assert err <= GOALS["median_pos_err_m"]
    # bad values are one line naming the option and the key
    too_slow = {**cardata_start_pose(rec, 0), "speed_mps": -1}
    for bad, words in (({"x": 0.0, "y": 0.0, "z": 0.0}, "yaw_rad is missing"), (too_slow, "speed_mps must be within")):
        with pytest.raises(UserError, match=words) as e:
            env.reset(options={"start_pose": bad})
        assert "\n" not in str(e.value) and "start_pose" in str(e.value)
    with pytest.raises(UserError, match="x must be a finite number"):
        env.reset(options={"start_pose": {"x": "1", "y": 0.0, "z": 0.0, "yaw_rad": 0.0}})
    env.close()
