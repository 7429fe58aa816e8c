"""Shared fixtures: the real OpenDS corpus in tests/data/opends-tasks and broken copies of it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# The corpus of real OpenDS tasks ships with the tests (tests/data/opends-tasks, see its README
# for origin and licence); OPENDS_CORPUS points at another corpus of the same layout.
DATA = ROOT / "tests" / "data"
CORPUS = Path(os.environ.get("OPENDS_CORPUS", DATA / "opends-tasks"))
# Real OpenDS drive logs (carData.txt) and the task they were driven on (tests/data/opends-drives).
DRIVES = DATA / "opends-drives"


def corpus_task_dirs() -> list[Path]:
    """Every task folder of the corpus (entry file inside), Schema folders excluded."""
    assert CORPUS.is_dir(), f"the OpenDS corpus is expected at {CORPUS}"
    return sorted(d for d in CORPUS.glob("*/*") if d.is_dir() and d.name != "Schema")


@pytest.fixture
def corpus() -> Path:
    assert CORPUS.is_dir(), f"the OpenDS corpus is expected at {CORPUS}"
    return CORPUS


def line_of(path: Path, needle: str) -> int:
    """1-based line of the first occurrence of `needle` in a file."""
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if needle in line:
            return i
    raise AssertionError(f"{needle!r} not in {path}")


@pytest.fixture
def task_copy(tmp_path: Path):
    """Copy a corpus task to tmp and optionally replace text in one of its files."""

    def make(task: str, file: str | None = None, old: str | None = None, new: str | None = None, count: int = 1) -> Path:
        src = CORPUS / task
        dst = tmp_path / src.name
        shutil.copytree(src, dst)
        if file is not None:
            f = dst / file
            text = f.read_text(encoding="utf-8")
            assert old is not None and new is not None and old in text, f"{old!r} not in {f}"
            f.write_text(text.replace(old, new, count), encoding="utf-8")
        return dst

    return make


def cli_output(argv: list[str]) -> tuple[int, str, str]:
    """`opends-gym ARGV`'s exit code, stdout and stderr, run in its own process: in-process,
    a command's output has reached pytest's global capture instead of capsys or a redirect
    in full parallel runs on a fresh clone (three tests so far), so assertions read ''."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "opends_gym.cli.main", *argv], capture_output=True, text=True, env=env, timeout=600)
    return proc.returncode, proc.stdout, proc.stderr
