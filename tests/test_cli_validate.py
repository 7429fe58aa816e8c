"""`opends-gym validate` and `opends-gym list` as a user runs them."""

from __future__ import annotations

import subprocess
import sys

from opends_gym.cli.main import main

from .conftest import CORPUS


def test_validate_corpus_recursively(capsys) -> None:
    code = main(["validate", str(CORPUS), "--recursive"])
    out = capsys.readouterr().out
    assert code == 0
    lines = [line for line in out.splitlines() if line.startswith("OK")]
    assert len(lines) == 8
    rt = next(line for line in lines if "reactionTest" in line)
    assert "triggers=23" in rt and "lanes=5" in rt and "actions=45" in rt
    assert "8 of 8 task(s) valid" in out


def test_validate_bundled_tasks_by_default(capsys) -> None:
    assert main(["validate"]) == 0
    assert "ReactionTest".lower() in capsys.readouterr().out.lower()


def test_validate_reports_a_broken_task_and_fails(task_copy, capsys) -> None:
    folder = task_copy("opends-cts/ReactionTest", "scenario.xml", "<xMin>-5.55</xMin>", "<xMin>left</xMin>")
    code = main(["validate", str(folder), str(CORPUS / "opends-cts" / "ConTReTask")])
    out = capsys.readouterr().out
    assert code == 1
    assert "ERROR" in out and "scenario.xml:" in out and "<xMin>" in out
    assert "1 of 2 task(s) valid" in out


def test_validate_shows_warnings(capsys) -> None:
    main(["validate", str(CORPUS / "opends2023-annegretj" / "init_drive"), "-w"])
    assert "falsse" in capsys.readouterr().out


def test_console_script_lists_bundled_tasks() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "opends_gym.cli.main", "list", "--tasks"], capture_output=True, text=True, check=True
    ).stdout
    assert "ReactionTest" in out
