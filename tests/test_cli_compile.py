"""`opends-gym compile` fills the machine's numba cache: a fresh process's first step then
compiles no kernel (it loads them), and a second run is fast because it compiles nothing."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from opends_gym.cli.main import main

# ConTRe's single env: the cheapest group to compile (a few kernels, no traffic)
COMPILE = [sys.executable, "-m", "opends_gym.cli.main", "compile", "--only", "ConTRe", "--kind", "single", "--jobs", "1"]
FIRST_STEP = r"""
import json
import gymnasium as gym
import numpy as np
import opends_gym
from opends_gym import jit
env = gym.make("OpenDS/ConTRe-v0")
env.reset(seed=0)
env.step(np.zeros(env.action_space.shape, dtype=env.action_space.dtype))
jit.wait_compiled()
print(json.dumps(jit.cache_stats()))
"""
LINE = re.compile(r"^OpenDS/ConTRe-v0 single env\s+[\d.]+ s\s+(\d+) compiled\s+(\d+) loaded from the cache$", re.M)


def _run(command: list[str], cache: Path) -> str:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "OPENDS_GYM_JIT_BACKGROUND": "1"}
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stdout


def _compile_counts(out: str) -> tuple[int, int]:
    m = LINE.search(out)
    assert m is not None, out
    return int(m.group(1)), int(m.group(2))


def test_first_step_after_compile_loads_every_kernel(tmp_path: Path) -> None:
    compiled, _ = _compile_counts(_run(COMPILE, tmp_path))
    assert compiled > 0  # the cache was empty: the kernels had to be compiled
    first = json.loads(_run([sys.executable, "-c", FIRST_STEP], tmp_path).strip().splitlines()[-1])
    assert first["compiled"] == 0, first  # without the compile step, this process would have compiled them
    assert first["loaded"] > 0, first
    again, loaded = _compile_counts(_run(COMPILE, tmp_path))  # idempotent: nothing left to compile
    assert (again, loaded > 0) == (0, True)


def test_unknown_env_id_is_one_line_with_a_suggestion(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compile", "--only", "LaneChangeTset"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "unknown environment id 'LaneChangeTset'; did you mean LaneChangeTest?" in err


def test_missing_task_folder_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "NoSuchTask"
    assert main(["compile", "--task", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"opends-gym compile: error: {missing}: no such task folder or file, nor a bundled task")
