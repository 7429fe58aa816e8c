"""A task file's warnings reach the log once per process, not on every `gym.make`."""

from __future__ import annotations

import logging
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.task.bundled import BUNDLED_DIR

from .conftest import ROOT


def _size_warnings(caplog: pytest.LogCaptureFixture, needle: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "opends_gym.task" and needle in r.getMessage()]


def test_second_make_of_a_task_logs_nothing_new(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "BrakeReaction"
    shutil.copytree(BUNDLED_DIR / "BrakeReaction", folder)
    scene = folder / "scene.xml"
    scene.write_text(scene.read_text(encoding="utf-8").replace('size="3"', 'size="2"', 1), encoding="utf-8")
    envs = []
    with caplog.at_level(logging.WARNING, logger="opends_gym.task"):
        for _ in range(2):
            envs.append(gym.make("OpenDS/DrivingTask-v0", task=str(folder)))
    found = _size_warnings(caplog, "vector declares size=2 but has 3 entries")
    assert len(found) == 1 and f"{scene}:11 <vector>" in found[0]  # file, line and element
    for env in envs:  # each loaded task still lists it
        assert any("declares size=2" in str(w) for w in env.unwrapped.task.warnings)
        env.close()
    assert capsys.readouterr().err == ""


def test_making_contre_twice_warns_at_most_once(caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]) -> None:
    with caplog.at_level(logging.WARNING, logger="opends_gym.task"):
        gym.make("OpenDS/ConTRe-v0").close()
        gym.make("OpenDS/ConTRe-v0").close()
    found = _size_warnings(caplog, "vector declares size=3 but has 4 entries")
    assert len(found) == len(set(found)) <= 2  # scene.xml lines 1679 and 1697, each at most once
    assert capsys.readouterr().err == ""


def test_a_script_making_contre_twice_sees_each_warning_once() -> None:
    script = "import gymnasium as gym, opends_gym\nfor _ in range(3): gym.make('OpenDS/ConTRe-v0').close()\n"
    err = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT).stderr
    lines = [line for line in err.splitlines() if "declares size" in line]
    assert len(lines) == 2 and len(set(lines)) == 2, err  # scene.xml:1679 and :1697, not once per make
