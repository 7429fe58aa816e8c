"""Cloning a driver from OpenDS carData.txt logs: run -> carData -> Minari -> train bc -> --agent bc.

The path a lab takes with its OpenDS logs (issue 22), on short drives of a virtual participant
written as carData.txt by our writer: the clone must drive the logged span within the
acceptance distance (5 m) of the path the logs took, and as far as they drove.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from opends_gym.cli.main import main
from opends_gym.record.cardata import read_cardata
from opends_gym.record.drive import load_drive

from .conftest import DRIVES

TASK = DRIVES / "Countryside"
SECONDS = 12.0
GOAL_M = 5.0  # issue 22: within 5 m of the path those drives took


def _quiet(argv: list[str]) -> int:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return main(argv)


def _path(xz: np.ndarray, step_m: float = 0.25) -> np.ndarray:
    """The polyline through xz, a point every step_m metres (log rows are ~1 m apart at speed)."""
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xz, axis=0).T))]
    at = np.arange(0.0, s[-1] + step_m, step_m)
    return np.c_[np.interp(at, s, xz[:, 0]), np.interp(at, s, xz[:, 1])]


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], list[Path]]:
    """Three 12 s drives of one virtual participant (seeds 0-2: its own motor noise) on the
    Countryside task from its start, recorded and written as OpenDS logs (`analyze --export-opends`)."""
    d = tmp_path_factory.mktemp("cs")
    run = ["run", str(TASK), "--agent", "participant:1", "--episodes", "3", "--max-seconds", str(SECONDS)]
    assert _quiet([*run, "--record", str(d / "p.mcap")]) == 0
    recordings = sorted(d.glob("p*.mcap"))
    assert len(recordings) == 3
    for k, rec in enumerate(recordings):
        assert _quiet(["analyze", str(rec), "--export-opends", str(d / f"log{k}")]) == 0
    return recordings, sorted(d.glob("log*/carData.txt"))


def test_exported_log_replays_the_actions_at_the_steps_they_were_taken(logs: tuple[list[Path], list[Path]]) -> None:
    from opends_gym.data.episodes import load_episode

    recording, log = logs[0][0], logs[1][0]
    taken = np.asarray(load_episode(recording).actions)  # the run's own actions
    replayed = np.asarray(load_episode(log, None, str(TASK)).actions)
    assert len(replayed) == len(taken)
    # as OpenDS writes a row: the inputs that drive the car from it (rounded as DataWriter rounds them)
    assert np.abs(replayed - taken).max() <= 1e-4


def test_clone_of_cardata_logs_drives_their_span_within_5_m_of_their_path(
    logs: tuple[list[Path], list[Path]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    cardata = logs[1]
    export = ["export", *map(str, cardata), "--task", str(TASK), "--trim-idle", "--env-arg", "on_collision=continue"]
    # with the road preview (the far point ahead): the dataset's env spec carries it, and so the clone's env
    assert _quiet([*export, "--env-arg", "road_preview_m=10,25,50", "--minari", "test/countryside"]) == 0
    import minari

    recovered = minari.load_dataset("test/countryside-v0").recover_environment()
    assert recovered.unwrapped.config.road_preview_m == (10.0, 25.0, 50.0)
    recovered.close()
    clone = tmp_path / "clone"
    assert _quiet(["train", "bc", "test/countryside-v0", "--out", str(clone), "--history", "15", "--epochs", "20"]) == 0
    drive_clone = ["run", str(TASK), "--agent", f"bc:{clone}", "--max-seconds", str(SECONDS)]
    assert _quiet([*drive_clone, "--record", str(tmp_path / "clone.mcap")]) == 0

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):  # refused without the preview, in one line
        assert main([*drive_clone, "--env-arg", "road_preview_m="]) == 2
    assert "trained with road_preview_m=(10.0, 25.0, 50.0)" in err.getvalue() and err.getvalue().count("\n") == 1
    drive = load_drive(tmp_path / "clone.mcap")
    xz = np.c_[drive.col("x_m"), drive.col("z_m")]
    logged = [np.c_[c.columns["x_m"], c.columns["z_m"]] for c in map(read_cardata, cardata)]
    distance = cKDTree(np.concatenate([_path(p) for p in logged])).query(xz)[0]
    driven = float(np.hypot(*np.diff(xz, axis=0).T).sum())
    least = min(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in logged)
    assert drive.col("t_s")[-1] >= SECONDS - 0.1  # it drove the whole span, nothing ended it
    assert distance.max() <= GOAL_M
    assert driven >= least - GOAL_M > 100.0  # it set off and kept up (one that stands still is on the path)


def test_a_wheel_log_cut_mid_drive_is_redriven_from_its_first_row(logs: tuple[list[Path], list[Path]], tmp_path: Path) -> None:
    from opends_gym.data.episodes import load_episode

    # a wheel is never exactly centred and the car is moving: the log has no settled row
    lines = logs[1][0].read_text().splitlines()
    cut = tmp_path / "carData.txt"
    cut.write_text("\n".join(lines[:4] + lines[4 + 100 :]) + "\n")  # from 5 s into the drive
    first = read_cardata(cut)
    assert first.columns["speed_kmh"][0] > 30.0 and np.all(first.columns["steering"] != 0.0)
    ep = load_episode(cut, None, str(TASK), {"on_collision": "continue"}, trim_idle=True)
    assert ep.start_pose is not None and ep.start_pose["x"] == pytest.approx(first.columns["x_m"][0])
    assert ep.steps == pytest.approx(first.t_s()[-1] * 10, abs=1)  # all of it, not its last row


ENGINE_LATE = DRIVES / "drives" / "2019_01_04-11_26_07" / "carData(2).txt"  # gas with the engine off, then starts it
NO_GAS = DRIVES / "drives" / "2019_01_04-11_26_07" / "carData.txt"  # 1.6 s standing, no pedal touched


def test_a_log_that_starts_its_engine_is_redriven_with_it_started() -> None:
    from opends_gym.data.episodes import load_episode
    from opends_gym.record.conform import Recorded

    rec = Recorded(ENGINE_LATE)
    assert rec.engine_on[0] == 0.0 and rec.engine_on[-1] == 1.0
    ep = load_episode(ENGINE_LATE, None, str(TASK))
    # the ignition key is turned where the log's engine comes on: the car sets off as it did (42.5 km/h at its end)
    assert ep.infos["speed_kmh"][-1] == pytest.approx(rec.speed_kmh[-1], abs=5.0)
    trimmed = load_episode(ENGINE_LATE, None, str(TASK), trim_idle=True)  # from the first gas with the engine running
    assert trimmed.start_pose is not None and trimmed.start_pose["engine_on"] == 1.0
    assert trimmed.infos["speed_kmh"][-1] == pytest.approx(rec.speed_kmh[-1], abs=5.0)


def test_export_trim_idle_skips_a_log_that_never_sets_off(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["export", str(NO_GAS), str(ENGINE_LATE), "--task", str(TASK), "--trim-idle", "--minari", "test/cs"])
    assert code == 0
    assert f"{NO_GAS}: never gives gas" in err.getvalue() and "skipped" in err.getvalue()
    import minari

    assert minari.load_dataset("test/cs-v0").total_episodes == 1
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["export", str(NO_GAS), "--task", str(TASK), "--trim-idle", "--minari", "test/none"])
    assert code == 2
    assert err.getvalue().strip().splitlines()[-1].endswith("no drive gives gas: nothing to export with --trim-idle")
