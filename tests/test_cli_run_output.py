"""What `opends-gym run` prints: episode rows, the `--csv` file and the progress bar."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from opends_gym.cli.main import main

FAST = ["run", "LaneChangeTest", "--agent", "random", "--max-seconds", "0.5"]


def test_table_has_a_row_per_episode_and_fits_the_terminal(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "100")
    assert main([*FAST, "--episodes", "100"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(len(line) for line in lines) <= 100
    starts = [line.split()[0] for line in lines if line and line.split()[0].isdigit()]
    # every block of columns lists the 100 episodes in order, one row each
    assert len(starts) % 100 == 0 and starts[:100] == [str(k) for k in range(100)]
    assert sum(line.startswith("mean ") for line in lines) == len(starts) // 100
    assert sum(line.startswith("sd ") for line in lines) == len(starts) // 100
    assert "same in every episode:" in lines  # steps (5) and the LCT's sign counts do not vary
    assert not any("wall_s" in line for line in lines) and lines[-1].startswith("wall time ")  # host speed: one line


def test_mean_and_sd_rows_match_the_episodes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*FAST, "--episodes", "4", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    returns = [e["return"] for e in result["episodes"]]
    mean = sum(returns) / 4
    sd = math.sqrt(sum((r - mean) ** 2 for r in returns) / 3)
    assert result["summary"]["return"]["mean"] == pytest.approx(mean)
    assert result["summary"]["return"]["sd"] == pytest.approx(sd)
    assert main([*FAST, "--episodes", "4"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.startswith("episode"))
    col = header.split().index("return") - 2  # "mean" and "sd" take the place of "episode seed end"
    assert float(next(line for line in lines if line.startswith("mean ")).split()[col]) == pytest.approx(mean, rel=1e-3)
    assert float(next(line for line in lines if line.startswith("sd ")).split()[col]) == pytest.approx(sd, rel=1e-3)


def test_csv_is_one_row_per_episode_with_every_metric(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "runs.csv"
    assert main([*FAST, "--episodes", "3", "--seed", "7", "--json", "--csv", str(out)]) == 0
    result = json.loads(capsys.readouterr().out)
    with out.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3
    assert list(rows[0])[:5] == ["env", "task", "agent", "seed", "episode"]
    for row, episode in zip(rows, result["episodes"]):
        assert (row["env"], row["task"], row["agent"]) == ("OpenDS/LaneChangeTest-v0", "laneChangeTest", "random")
        assert (int(row["seed"]), int(row["episode"])) == (episode["seed"], episode["episode"])
        assert set(episode) - {"seed", "episode"} <= set(row)  # every metric, per-sign ones included
        for key, value in episode.items():
            if isinstance(value, bool):
                assert row[key] == ("TRUE" if value else "FALSE")
            elif value is None:  # NaN or infinite in the JSON
                assert row[key] in ("NA", "Inf", "-Inf")
            elif isinstance(value, (int, float)) and key not in ("seed", "episode"):
                assert float(row[key]) == value  # full precision
    assert (rows[0]["min_ttc_s"], rows[0]["mean_headway_s"]) == ("Inf", "NA")  # no lead car on the LCT: R and pandas spellings


def test_progress_bar_only_when_asked_or_on_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*FAST, "--episodes", "3"]) == 0
    assert capsys.readouterr().err == ""  # stderr is not a terminal here
    assert main([*FAST, "--episodes", "3", "--progress"]) == 0
    err = capsys.readouterr().err
    assert "episode 1/3" in err and "episode 3/3" in err and "100%" in err and err.endswith("\n")
    assert main([*FAST, "--episodes", "3", "--progress", "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and json.loads(captured.out)["episodes"][2]["seed"] == 2


def test_progress_bar_draws_on_a_terminal() -> None:
    """stderr a pseudo-terminal, as in an interactive shell: the bar appears without --progress."""
    import os
    import pty
    import subprocess
    import sys

    from .conftest import ROOT

    master, slave = pty.openpty()
    try:
        cmd = [sys.executable, "-m", "opends_gym.cli.main", *FAST, "--episodes", "2"]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=slave, cwd=ROOT, timeout=300, check=True)
    finally:
        os.close(slave)
    err = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the terminal's other end is closed and everything was read
            break
        if not chunk:
            break
        err += chunk
    os.close(master)
    assert b"episode 2/2" in err and b"\r" in err
    assert b"episode 2/2" not in proc.stdout  # the tables stay on stdout, the bar on stderr
