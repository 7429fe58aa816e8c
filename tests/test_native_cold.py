"""A native batch on a machine whose numba cache lacks its kernels (a fresh install without
`opends-gym compile`) steps at once: its kernels run as Python while a child process compiles
them, with the results of the compiled kernels, and the child never outlives an ended
program except to finish the compiles it was handed (`opends_gym.jit`)."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym import jit

ROOT = Path(__file__).resolve().parent.parent
MOTORWAY = str(ROOT / "tests" / "data" / "opends-tasks" / "opends-cts" / "MotorwayTask")  # (41 traffic cars, triggers)
BATCHES = ("OpenDS/LaneChangeTest-v0", "OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0", "OpenDS/DrivingTask-v0")
TASKS = {"OpenDS/DrivingTask-v0": MOTORWAY}
ENVS, STEPS = 4, 120

COLD_RUN = r"""
import json, os, pickle, sys
sys.path.insert(0, sys.argv[2])
from opends_gym import jit
from test_native_cold import BATCHES, drive
runs = {}
for env_id in BATCHES:
    runs[env_id] = drive(env_id)
    runs[env_id + " status"] = jit.compile_status()
with open(sys.argv[1], "wb") as f:
    pickle.dump(runs, f)
os._exit(0)  # (as a crash would: the compile child must end with us)
"""


def drive(env_id: str) -> dict[str, Any]:
    """Observations, rewards, ends and ended episodes' metrics of a short random drive."""
    task = {"task": TASKS[env_id]} if env_id in TASKS else {}
    env = gym.make_vec(env_id, num_envs=ENVS, vectorization_mode="vector_entry_point", max_episode_s=6.0, **task)
    obs, _ = env.reset(seed=5)
    rng = np.random.default_rng(7)
    out: dict[str, Any] = {"obs": [obs.copy()], "reward": [], "ended": [], "metrics": []}
    for _ in range(STEPS):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        out["obs"].append(obs.copy())
        out["reward"].append(reward.copy())
        out["ended"].append(terminated | truncated)
        if "episode_metrics" in info:
            out["metrics"].append({k: np.asarray(v).copy() for k, v in info["episode_metrics"].items()})
    env.close()
    return out


def _children(cache: Path) -> list[int]:
    """Compile children (`opends_gym.jit_child`) of programs run with numba cache `cache`."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
            environ = Path(f"/proc/{pid}/environ").read_bytes()
        except OSError:
            continue
        if b"opends_gym.jit_child" in cmdline and f"NUMBA_CACHE_DIR={cache}".encode() in environ.split(b"\0"):
            found.append(int(pid))
    return found


def _gone(cache: Path, within_s: float) -> bool:
    deadline = time.monotonic() + within_s
    while _children(cache):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.2)
    return True


def _run(code: str, cache: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT), "OPENDS_GYM_JIT_BACKGROUND": "1"}
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    return done


def test_a_cold_native_batch_steps_as_python_with_the_compiled_results(tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    _run(COLD_RUN, cache, str(tmp_path / "cold.pkl"), str(Path(__file__).parent))
    with open(tmp_path / "cold.pkl", "rb") as f:
        cold = pickle.load(f)
    assert _gone(cache, 10.0)  # the program ended without detaching it: its compile child ended too
    for env_id in BATCHES:
        status = cold[env_id + " status"]
        assert status["python_calls"] > 0 and status["pending"] > 0, status  # ran as Python, compiles still queued
        with jit.compile_in_call():  # this process: compiled kernels (loaded from the test run's cache)
            warm = drive(env_id)
        for key in ("obs", "reward", "ended"):
            np.testing.assert_array_equal(np.array(cold[env_id][key]), np.array(warm[key]), err_msg=f"{env_id} {key}")
        assert len(cold[env_id]["metrics"]) == len(warm["metrics"]) > 0, env_id
        for got, want in zip(cold[env_id]["metrics"], warm["metrics"], strict=True):
            assert list(got) == list(want)
            for key in want:
                assert got[key].dtype == want[key].dtype, (env_id, key)
                np.testing.assert_array_equal(got[key], want[key], err_msg=f"{env_id} {key}")


DETACH = r"""
import json, sys
from opends_gym import jit
from opends_gym.vector.kernels import chunk_count
print(json.dumps({"chunks": chunk_count(1000), **jit.compile_status()}))
"""  # then a normal exit: the queued compile is left to the compile child

LOAD = r"""
import json
from opends_gym import jit
from opends_gym.vector.kernels import chunk_count
with jit.compile_in_call():
    chunks = chunk_count(1000)
print(json.dumps({"chunks": chunks, **jit.cache_stats()}))
"""


def test_an_ending_program_leaves_its_native_compiles_to_the_child_which_fills_the_cache(tmp_path: Path) -> None:
    first = json.loads(_run(DETACH, tmp_path).stdout)
    assert first["python_calls"] == 1 and first["pending"] == 1, first  # ran as Python, compile queued
    assert _gone(tmp_path, 120.0)  # the child finished the compile, then ended
    second = json.loads(_run(LOAD, tmp_path).stdout)
    assert second == {"chunks": first["chunks"], "compiled": 0, "loaded": 1}  # machine code from the child's compile


FORKED = r"""
import os, sys, time
from opends_gym.vector.kernels import chunk_count
chunk_count(1000)  # queued: the background thread starts the compile child
time.sleep(1.0)
fork = os.fork()
if fork == 0:  # a forked worker that outlives its parent for a while
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    time.sleep(60)
    os._exit(0)
print(fork, flush=True)
os._exit(0)
"""


def test_the_compile_child_ends_with_its_program_while_a_fork_of_it_lives_on(tmp_path: Path) -> None:
    fork = int(_run(FORKED, tmp_path).stdout.split()[-1])
    try:
        assert _gone(tmp_path, 10.0)  # the fork closed its copies of the child's pipes
    finally:
        os.kill(fork, 9)
