"""`opends-gym study`: a tiny study end to end through the CLI (table, determinism across
workers, mixed model, report), the power analysis against the analytic sample size, one-line
errors for a broken STUDY.yaml, and the Latin-square order of human sessions."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from opends_gym.cli.main import main
from opends_gym.study.analysis import summarize
from opends_gym.study.config import load_study
from opends_gym.study.human import plan_blocks, williams_row
from tests.conftest import line_of

TINY = """\
name: tiny
seed: 3
participants: 3
tasks:
  lct:
    env: LaneChangeTest
    max_seconds: 20
    metrics: [sdlp_m, mean_speed_kmh]
conditions:
  attentive: {agent: "distracted:none"}
  heavy: {agent: "distracted:heavy", instructions: "Read the display aloud while driving."}
power: {simulations: 200, max_n: 60}
bootstrap: 200
"""


def write(tmp_path: Path, text: str, name: str = "study.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def tiny_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("study")
    study = write(tmp, TINY)
    assert main(["study", str(study), "--out", str(tmp / "w1"), "--workers", "1", "--no-progress"]) == 0
    assert main(["study", str(study), "--out", str(tmp / "w2"), "--workers", "2", "--no-progress"]) == 0
    return tmp / "w1", tmp / "w2"


def test_the_table_has_a_row_per_participant_condition_task_trial_and_metric(tiny_runs: tuple[Path, Path]) -> None:
    out = tiny_runs[0]
    table = pd.read_csv(out / "table.csv")
    assert list(table.columns) == ["participant", "source", "condition", "task", "trial", "metric", "value"]
    assert len(table) == 3 * 2 * 1 * 1 * 2  # participants x conditions x tasks x repetitions x metrics
    assert sorted(table["participant"].unique()) == ["V001", "V002", "V003"]
    assert set(table["source"]) == {"virtual"} and set(table["condition"]) == {"attentive", "heavy"}
    assert set(table["metric"]) == {"sdlp_m", "mean_speed_kmh"} and np.isfinite(table["value"]).all()
    pd.testing.assert_frame_equal(pd.read_parquet(out / "table.parquet"), table)
    # the distracted driver weaves more than the attentive one, participant by participant
    sdlp = table[table.metric == "sdlp_m"].pivot(index="participant", columns="condition", values="value")
    assert (sdlp["heavy"] > sdlp["attentive"]).all()


def test_any_worker_count_gives_the_same_table(tiny_runs: tuple[Path, Path]) -> None:
    one, two = tiny_runs
    assert (one / "table.csv").read_bytes() == (two / "table.csv").read_bytes()
    assert (one / "summary.csv").read_bytes() == (two / "summary.csv").read_bytes()


def test_the_summary_has_the_mixed_model_effect_sizes_and_power(tiny_runs: tuple[Path, Path]) -> None:
    out = tiny_runs[0]
    summary = pd.read_csv(out / "summary.csv")
    row = summary[(summary.metric == "sdlp_m") & (summary.condition == "heavy")].iloc[0]
    assert row["reference"] == "attentive" and row["n"] == 3
    # balanced within-subject design: the MixedLM condition coefficient is the mean paired difference
    assert row["mixedlm_coef"] == pytest.approx(row["difference"], rel=1e-6)
    assert row["mixedlm_low"] < row["mixedlm_coef"] < row["mixedlm_high"]
    assert row["difference_low"] < row["difference"] < row["difference_high"]
    assert row["cohens_dz"] > 0 and 2 <= row["power_n"] <= 60
    html = (out / "report.html").read_text(encoding="utf-8")
    assert html.count("<img") == 2 and "sdlp_m" in html and "Cohen" in html


def analytic_paired_n(dz: float, alpha: float = 0.05, power: float = 0.8) -> int:
    """Smallest n whose two-sided paired t-test reaches `power` (noncentral t; Cohen 1988, ch. 2)."""
    for n in range(2, 10_000):
        crit = stats.t.ppf(1 - alpha / 2, n - 1)
        nc = dz * math.sqrt(n)
        if stats.nct.sf(crit, n - 1, nc) + stats.nct.cdf(-crit, n - 1, nc) >= power:
            return n
    raise AssertionError("no n")


@pytest.mark.parametrize("effect", [0.5, 0.8])
def test_the_power_analysis_finds_the_analytic_sample_size(effect: float) -> None:
    rng = np.random.default_rng(7)
    n = 500
    base = rng.normal(10.0, 2.0, n)
    cond = base + rng.normal(effect, 1.0, n)  # difference SD 1: d_z = effect
    people = [f"P{k}" for k in range(n)]
    rows = [(p, "virtual", c, "t", 0, "m", v) for p, b, x in zip(people, base, cond) for c, v in (("a", b), ("b", x))]
    table = pd.DataFrame(rows, columns=["participant", "source", "condition", "task", "trial", "metric", "value"])
    (e,) = summarize(table, ["a", "b"], "a", simulations=2000, max_n=200, bootstrap=300, seed=1)
    expected = analytic_paired_n(e.cohens_dz)
    assert e.dz_low < effect < e.dz_high
    assert abs(e.power_n - expected) <= max(2, 0.12 * expected), (e.power_n, expected)


def test_a_typo_in_the_study_is_one_line_naming_file_line_and_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, TINY.replace("conditions:", "conditons:"))
    assert main(["study", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert f"{path}:{line_of(path, 'conditons')}: conditons: unknown key; did you mean conditions?" in err
    path = write(tmp_path, TINY.replace("  lct:\n", "  lct:\n    mterics: [x]\n"))
    assert main(["study", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{path}:{line_of(path, 'mterics')}: tasks.lct.mterics: unknown key; did you mean metrics?" in err and "\n" not in err
    path = write(tmp_path, TINY.replace('{agent: "distracted:none"}', '{agent: "distracted:none", env_args: {polcy_hz: 5}}'))
    assert main(["study", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{path}:{line_of(path, 'polcy_hz')}: conditions.attentive.env_args.polcy_hz: not an option" in err
    assert "did you mean policy_hz?" in err
    path = write(tmp_path, TINY.replace("participants: 3", "participants: [3"))
    assert main(["study", str(path)]) == 2
    assert f"{path}:{line_of(path, 'participants') + 1}: invalid YAML" in capsys.readouterr().err


def test_no_typo_is_missed_at_the_top(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, TINY.replace("seed: 3", "sed: 3"))
    assert main(["study", str(path)]) == 2
    assert f"{path}:2: sed: unknown key; did you mean seed?" in capsys.readouterr().err


def test_human_condition_order_is_a_balanced_latin_square(tmp_path: Path) -> None:
    for n in (2, 4, 6):
        rows = [williams_row(n, r) for r in range(n)]
        for k in range(n):  # every condition once in every position
            assert sorted(r[k] for r in rows) == list(range(n))
        pairs = {(r[k], r[k + 1]) for r in rows for k in range(n - 1)}
        assert len(pairs) == n * (n - 1)  # even n: every condition follows every other once
    study = load_study(write(tmp_path, TINY))
    assert [b.condition for b in plan_blocks(study, "P01")] == ["attentive", "heavy"]
    assert [b.condition for b in plan_blocks(study, "P02")] == ["heavy", "attentive"]


def test_ray_gives_the_same_table_as_the_process_pool(tiny_runs: tuple[Path, Path], tmp_path: Path) -> None:
    study = write(tmp_path, TINY + "ray: true\n")
    assert main(["study", str(study), "--out", str(tmp_path / "ray"), "--no-progress"]) == 0
    assert (tmp_path / "ray" / "table.csv").read_bytes() == (tiny_runs[0] / "table.csv").read_bytes()


@pytest.mark.parametrize("name", ["lct_load", "brake", "drt", "drivers"])
def test_the_shipped_example_studies_load_by_name(name: str) -> None:
    from opends_gym.drivers.population import LOADS

    study = load_study(name)
    assert study.path.name == f"{name}.yaml" and study.reference == "baseline"
    # the virtual participants drive under a visual-manual and a cognitive load (the drivers study adds the rule driver)
    assert {"baseline", "visual_manual", "cognitive"} <= {c.load for c in study.conditions} <= {*LOADS, None}
    assert study.agent == "participant:{participant}:{load}"
    assert [c.agent for c in study.conditions if c.agent is not None] == (["rule"] if name == "drivers" else [])


def test_on_road_exit_goes_only_to_envs_that_have_the_option(tmp_path: Path) -> None:
    from opends_gym.study.config import env_fields
    from opends_gym.study.design import env_args_for, expand

    study = load_study(write(tmp_path, TINY.replace("seed: 3", "seed: 3\non_road_exit: recover")))
    task, cond = study.tasks[0], study.conditions[0]
    assert env_args_for(study, task, cond, {"on_road_exit"})["on_road_exit"] == "recover"
    assert "on_road_exit" not in env_args_for(study, task, cond, {"policy_hz"})
    has_option = "on_road_exit" in env_fields(task.env_id)  # before and after envs gain the option
    assert all(("on_road_exit", "recover") in t.env_args for t in expand(study)) == has_option


@pytest.mark.parametrize(("key", "goes_on"), [("K_RETURN", True), ("K_ESCAPE", False)])
def test_the_instruction_page_waits_for_return_and_escape_ends_the_session(
    monkeypatch: pytest.MonkeyPatch, key: str, goes_on: bool
) -> None:
    import pygame

    from opends_gym.study.instructions import show_instructions

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pygame.display.init()
    pygame.display.set_mode((8, 8))
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=getattr(pygame, key)))  # the person's key press
    assert show_instructions("Block 1 of 2", "Count backwards in sevens.", window=True, auto_advance=False, size=(320, 200)) is goes_on
    assert show_instructions("Block 1 of 2", "headless", window=False, auto_advance=False) is True
