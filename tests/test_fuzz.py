"""Seeded fuzzing of real tasks and real drives (issue 21): every broken copy either fails
with one clean error naming its file and line, or works (an env that makes, resets and
steps with finite observations; a drive that loads and analyses).

The mutants (tests/task_mutants.py) change one file of one real task in one way. The
3 MB ReactionTest is left out to keep this in CI time (a load costs 1 s); the hostile-value
tests in test_hardening_task.py cover what the fuzzer would find there.
"""

from __future__ import annotations

import logging
import random
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.record.analyze import analyze
from opends_gym.record.drive import load_drive
from opends_gym.task import TaskError, load_task

from .conftest import DRIVES, corpus_task_dirs
from .task_mutants import HOSTILE_VALUES, make_mutant

TASK_MUTANTS = 240
DRIVE_MUTANTS = 40


def _small_tasks() -> list[Path]:
    dirs = corpus_task_dirs() + [DRIVES / "Countryside"]
    return [d for d in dirs if sum(p.stat().st_size for p in d.iterdir()) < 1_000_000]


def _check_task_error(e: TaskError, folder: Path) -> None:
    text = str(e)
    assert "\n" not in text and len(text) < 600, text
    assert e.file is not None, text
    if Path(e.file) == folder:  # a folder-level error: no entry file at all
        assert "no entry file" in text
        return
    assert Path(e.file).parent == folder and e.line is not None and f"{Path(e.file).name}:{e.line}" in text, text


def _works(folder: Path) -> None:
    env = gym.make("OpenDS/DrivingTask-v0", task=str(folder), disable_env_checker=True)
    try:
        obs, _ = env.reset(seed=0)
        for _ in range(3):
            obs, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        assert np.isfinite(obs).all()
    finally:
        env.close()


def test_task_mutants_fail_cleanly_or_work(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="opends_gym")  # mutants warn a lot; that is fine
    rng = random.Random(2021)
    tasks = _small_tasks()
    assert len(tasks) >= 7
    outcomes = {"error": 0, "works": 0}
    for i in range(TASK_MUTANTS):
        m = make_mutant(rng.choice(tasks), tmp_path, rng, i)
        try:
            load_task(m.folder)
        except TaskError as e:
            _check_task_error(e, m.folder)
            outcomes["error"] += 1
            continue
        try:
            _works(m.folder)
        except Exception as e:
            raise AssertionError(f"{m}: loads but the env fails: {type(e).__name__}: {e}") from e
        outcomes["works"] += 1
    assert min(outcomes.values()) >= TASK_MUTANTS // 5  # both kinds are exercised


def test_drive_mutants_fail_cleanly_or_analyse(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="opends_gym")
    rng = random.Random(2021)
    files = [f for f in sorted((DRIVES / "drives").rglob("carData*.txt")) if f.stat().st_size < 20_000]
    assert files
    for i in range(DRIVE_MUTANTS):
        lines = rng.choice(files).read_text(encoding="utf-8").splitlines(keepends=True)
        k = rng.randrange(len(lines))
        op = rng.choice(["value", "delete", "duplicate", "cut", "char"])
        if op == "value":
            parts = lines[k].rstrip("\n").split(":")
            parts[rng.randrange(len(parts))] = rng.choice(HOSTILE_VALUES)
            lines[k] = ":".join(parts) + "\n"
        elif op == "delete":
            del lines[k]
        elif op == "duplicate":
            lines.insert(k, lines[k])
        elif op == "cut":
            lines = [*lines[:k], lines[k][: rng.randrange(len(lines[k]) + 1)]]
        else:
            n = rng.randrange(len(lines[k]) + 1)
            lines[k] = lines[k][:n] + rng.choice(["\x00", ":", "\u00e9", "-", "1_0"]) + lines[k][n:]
        path = tmp_path / f"m{i}" / "carData.txt"
        path.parent.mkdir()
        path.write_text("".join(lines), encoding="utf-8")
        try:
            drive = load_drive(path, task=DRIVES / "Countryside")
        except ValueError as e:
            text = str(e)
            assert "\n" not in text and (re.search(r"carData\.txt:\d+: ", text) or text.endswith("carData file without rows")), text
            continue
        a = analyze(drive)
        assert all(np.isfinite(v) or np.isnan(v) for v in a.summary.values() if isinstance(v, float)), (op, k)


@pytest.mark.parametrize("value", ["1_0", "١٢", "１０", "1e39", "-1e39"])
def test_drive_rows_take_only_java_numbers(tmp_path: Path, value: str) -> None:
    src = DRIVES / "drives" / "2019_01_04-11_26_07" / "carData.txt"
    lines = src.read_text(encoding="utf-8").splitlines(keepends=True)
    parts = lines[5].split(":")
    parts[1] = value
    lines[5] = ":".join(parts)
    path = tmp_path / "carData.txt"
    path.write_text("".join(lines), encoding="utf-8")
    with pytest.raises(ValueError, match=r"carData\.txt:6: "):
        load_drive(path)
