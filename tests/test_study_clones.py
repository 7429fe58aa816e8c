"""A behaviour clone trained with a road preview as a study's agent: its trials' envs carry the
clone's observation options (`study.clones`), a study that sets them otherwise is one line."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pandas as pd
import pytest

from opends_gym.cli.main import main

from .conftest import cli_output, line_of

PREVIEW = (10.0, 25.0)
STUDY = """\
name: clone
seed: 1
participants: 2
tasks:
  lct:
    env: LaneChangeTest
    max_seconds: 2
    metrics: [mean_speed_kmh, distance_m]
conditions:
  steady: {agent: "constant:0.0,0.5"}
  clone: {agent: "bc:CLONE"}
power: {simulations: 20, max_n: 10}
bootstrap: 20
"""


@pytest.fixture(scope="module")
def clone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A clone of a constant driver (steer 0.02, gas 0.7), its dataset recorded with the road preview."""
    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent

    d = tmp_path_factory.mktemp("clone")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MINARI_DATASETS_PATH", str(d / "minari"))
        env = make_env("OpenDS/LaneChangeTest-v0", {"max_episode_s": 2.0, "road_preview_m": PREVIEW})
        write_dataset("test/preview", [collect(env, make_agent("constant:0.02,0.7"), seed) for seed in (0, 1)])
        env.close()
        summary = train_bc("test/preview-v0", d / "clone", BCConfig(epochs=40, validation=0.0))
    assert summary["env_kwargs"] == {"road_preview_m": list(PREVIEW)}
    return d / "clone"


def _study(tmp_path: Path, clone: Path, task_args: str = "") -> Path:
    text = STUDY.replace("CLONE", str(clone))
    if task_args:
        text = text.replace("    max_seconds: 2\n", f"    max_seconds: 2\n    env_args: {task_args}\n")
    path = tmp_path / "study.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_study_runs_a_clone_in_the_env_it_was_trained_with(clone: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["study", str(_study(tmp_path, clone)), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    table = pd.read_csv(out / "table.csv")
    rows = table[table["condition"] == "clone"]
    assert sorted(rows["participant"].unique()) == ["V001", "V002"] and len(rows) == 2 * 2  # two metrics each
    speed = rows[rows["metric"] == "mean_speed_kmh"]["value"]
    assert speed.notna().all() and (speed > 0).all()  # it drove (gas, as the driver it cloned)
    # the same preview given by the study is the clone's: the same table
    same = tmp_path / "same"
    path = _study(tmp_path, clone, "{road_preview_m: [10, 25]}")
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["study", str(path), "--out", str(same), "--workers", "1", "--no-progress"]) == 0
    assert pd.read_csv(same / "table.csv").equals(table)


def test_a_study_that_sets_the_clones_option_otherwise_is_one_line(clone: Path, tmp_path: Path) -> None:
    path = _study(tmp_path, clone, "{road_preview_m: [10, 50]}")
    code, _, err = cli_output(["study", str(path), "--out", str(tmp_path / "o"), "--no-progress"])
    assert code == 2 and err.strip().count("\n") == 0, err
    where = f"{path}:{line_of(path, 'road_preview_m')}: tasks.lct.env_args.road_preview_m:"
    assert where in err and f"condition clone's agent bc:{clone} was trained with road_preview_m=(10.0, 25.0)" in err


def test_a_clones_drive_is_placed_against_a_population_on_its_env(clone: Path, tmp_path: Path) -> None:
    """`run --agent bc:` records the env with the clone's preview; `analyze --against
    population:N` replays it and simulates the participants on that env and its options."""
    rec = tmp_path / "clone.mcap"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", "LaneChangeTest", "--agent", f"bc:{clone}", "--max-seconds", "2", "--record", str(rec)]) == 0
    code, out, err = cli_output(["analyze", str(rec), "--against", "population:2", "--json"])
    assert code == 0, err
    against = json.loads(out)["against"]
    assert against["reference"] == "2 virtual participants (baseline) on OpenDS/LaneChangeTest-v0"
    assert against["metrics"]["mean_speed_kmh"]["n"] == 2
