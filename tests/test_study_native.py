"""`opends-gym study` on the native batch: the virtual participants drive the LCT's native
batch slot by slot, and the long-format table is the single env's, row for row (drives that
leave the road included: they are driven again on the single env under `recover`); the
backend is chosen from the study or the CLI, with one-line errors where it cannot be."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pandas as pd
import pytest

from opends_gym.cli.main import main
from opends_gym.drivers.intent import Intent
from opends_gym.drivers.percept import Percept, evolve
from opends_gym.study.backend import run_trials
from opends_gym.study.config import load_study
from opends_gym.study.design import expand
from opends_gym.study.runner import COLUMNS
from tests.conftest import line_of

# 3 participants x 2 loads; `edge` puts the road's edge 7.5 cm past the outer lanes' centres
# (margin -1.8 m of a 3-lane, 3.75 m lane road), so drives there leave the road and recover
SMALL = """\
name: native_small
seed: 11
participants: 3
backend: {backend}
on_road_exit: recover
tasks:
  lct:
    env: LaneChangeTest
    env_args: {{scoring: iso26022}}
    max_seconds: 30
    metrics: [iso_mdev_m, iso_wrong_lane, sdlp_j2944_m, steering_reversal_rate_2deg_per_min, glance_count,
              glance_total_eyes_off_road_s, distance_m, signs_reached, resets]
  edge:
    env: LaneChangeTest
    env_args: {{off_road_margin_m: -1.8}}
    max_seconds: 30
    metrics: [mdev_basic_m, distance_m, resets]
conditions:
  baseline: {{load: baseline}}
  visual_manual: {{load: visual_manual}}
power: {{simulations: 50, max_n: 20}}
bootstrap: 50
"""


def _rows(tmp: Path, backend: str) -> pd.DataFrame:
    """The study's long-format rows (what table.csv holds) from `backend`."""
    study = tmp / f"{backend}.yaml"
    study.write_text(SMALL.format(backend=backend), encoding="utf-8")
    s = load_study(str(study))
    rows = run_trials(expand(s), s.participants, s.seed, backend=s.backend)
    return pd.DataFrame(rows, columns=list(COLUMNS))


@pytest.fixture(scope="module")
def tables(tmp_path_factory: pytest.TempPathFactory) -> tuple[pd.DataFrame, pd.DataFrame]:
    tmp = tmp_path_factory.mktemp("native")
    return _rows(tmp, "single"), _rows(tmp, "native")


def test_the_native_table_is_the_single_env_table(tables: tuple[pd.DataFrame, pd.DataFrame]) -> None:
    single, native = tables
    assert len(single) == 3 * 2 * (9 + 3)  # participants x conditions x metrics of both tasks
    pd.testing.assert_frame_equal(native, single, check_exact=True)  # (NaN where single has NaN)


def test_drives_that_leave_the_road_recover_in_the_native_table(tables: tuple[pd.DataFrame, pd.DataFrame]) -> None:
    native = tables[1]
    resets = native[(native["task"] == "edge") & (native["metric"] == "resets")]["value"]
    assert (resets > 0).any()  # the batch ends a drive off the road; the study's recover drives it on
    glances = native[(native["condition"] == "visual_manual") & (native["metric"] == "glance_count")]["value"]
    assert (glances > 0).all()  # the participant's glance process ran in the slots


ONE = """\
name: one
participants: 1
backend: single
tasks:
  lct: {env: LaneChangeTest, max_seconds: 10, metrics: [mdev_basic_m]}
conditions:
  baseline: {load: baseline}
  cognitive: {load: cognitive}
power: {simulations: 20, max_n: 10}
bootstrap: 20
"""


def test_the_cli_backend_overrides_the_study_and_the_summary_says_which_ran(tmp_path: Path) -> None:
    study = tmp_path / "s.yaml"
    study.write_text(ONE, encoding="utf-8")
    assert main(["study", str(study), "--out", str(tmp_path / "o"), "--no-progress", "--backend", "native"]) == 0
    summary = json.loads((tmp_path / "o" / "summary.json").read_text(encoding="utf-8"))
    assert summary["backend"] == "native" and summary["cpu_s"] > 0


def test_backend_native_names_the_task_it_cannot_batch(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = SMALL.format(backend="native").replace("participants: 3", "participants: 1")
    text = text.replace("  baseline: {load: baseline}", "  baseline: {load: baseline, drt: {modality: tactile}}")
    study = tmp_path / "s.yaml"
    study.write_text(text, encoding="utf-8")
    assert main(["study", str(study), "--out", str(tmp_path / "o"), "--no-progress"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "backend native" in err[0] and "task lct, condition baseline" in err[0] and "DRT" in err[0]


def test_an_unknown_backend_is_one_line_naming_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    study = tmp_path / "s.yaml"
    study.write_text(SMALL.format(backend="gpu"), encoding="utf-8")
    assert main(["study", str(study), "--out", str(tmp_path / "o"), "--no-progress"]) != 0
    err = capsys.readouterr().err.strip()
    assert f"{study}:{line_of(study, 'backend:')}" in err and "backend" in err and "gpu" in err


def test_the_participants_fast_replace_makes_what_dataclasses_replace_makes() -> None:
    p = Percept(t_s=1.0, speed_mps=16.0, lateral_m=0.2, heading_error_rad=0.01, yaw_rate_radps=0.0, target_lateral_m=3.75, cruise_mps=16.7)
    changed = {"lateral_m": -0.4, "sign_distance_m": 12.0, "lane_change_pending": True}
    assert evolve(p, **changed) == dataclasses.replace(p, **changed) and p.lateral_m == 0.2
    assert evolve(Intent(steering=0.3), pedal=0.5) == Intent(steering=0.3, pedal=0.5)
    with pytest.raises(TypeError, match="no field lateral"):
        evolve(p, lateral=1.0)
