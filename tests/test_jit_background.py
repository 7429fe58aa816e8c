"""Kernels compile in the background (in a child process; a thread loads them): a first call
with no machine code runs the kernel as Python instead of waiting for numba, with the same
results, and the compiled code lands in the machine's cache (`opends_gym.jit`)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401
from opends_gym import jit

ROOT = Path(__file__).resolve().parent.parent

LCT_STEPS = r"""
import json, os, sys
import gymnasium as gym
import numpy as np
import opends_gym
from opends_gym import jit
env = gym.make("OpenDS/LaneChangeTest-v0")
obs, _ = env.reset(seed=3)
first = jit.compile_status()
rows = [obs.tolist()]
actions = np.random.default_rng(0).uniform(-0.05, 0.05, (40, 2)).astype(np.float32)
for a in actions:
    obs, reward, *_ = env.step(a)
    rows.append(obs.tolist() + [reward])
print(json.dumps({"status": first, "rows": rows}))
sys.stdout.flush()
os._exit(0)  # (not waiting for the background compiles: this test is about the calls before them)
"""

HYPOT = r"""
import json
from opends_gym import jit
first = jit.py_hypot(3e-310, 4e-310)
after_first = jit.compile_status()
jit.wait_compiled()
second = jit.py_hypot(3e-310, 4e-310)
print(json.dumps({"first": first, "second": second, "after_first": after_first, "after_second": jit.compile_status()}))
"""


FORK = r"""
import json, os
from opends_gym import jit
jit.py_hypot(3.0, 4.0)  # queued (or compiling) in the parent when it forks
pid = os.fork()
if pid == 0:  # the child compiles on its own thread, and the compile finishes
    jit.py_hypot(3.0, 4.0)
    jit.wait_compiled()
    os._exit(0 if jit.compile_status()["pending"] == 0 else 3)
_, status = os.waitpid(pid, 0)
print(json.dumps({"child": os.waitstatus_to_exitcode(status)}))
"""


def _child(code: str, cache: Path) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT), "OPENDS_GYM_JIT_BACKGROUND": "1"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_first_steps_with_an_empty_cache_run_as_python_with_the_compiled_results(tmp_path: Path) -> None:
    """A fresh install (empty numba cache): reset and the first steps do not wait for the
    compile, they run the kernels as Python while it proceeds, and give exactly what the
    compiled kernels give."""
    cold = _child(LCT_STEPS, tmp_path / "cache")
    assert cold["status"]["python_calls"] > 0 and cold["status"]["pending"] > 0  # reset returned before any compile finished

    env = gym.make("OpenDS/LaneChangeTest-v0")
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    jit.wait_compiled()  # this process: compiled (or loaded from the repository's cache)
    obs, _ = env.reset(seed=3)
    rows = [obs.tolist()]
    for a in np.random.default_rng(0).uniform(-0.05, 0.05, (40, 2)).astype(np.float32):
        obs, reward, *_ = env.step(a)
        rows.append(obs.tolist() + [reward])
    calls = jit.compile_status()["python_calls"]
    env.step(np.zeros(2, dtype=np.float32))
    assert jit.compile_status()["python_calls"] == calls  # compiled now: no call runs as Python
    assert cold["rows"] == rows  # bit for bit (JSON floats round-trip exactly)


def test_the_background_compile_fills_the_cache_and_takes_over(tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    out = _child(HYPOT, cache)
    assert out["first"] == out["second"] == math.hypot(3e-310, 4e-310)
    assert out["after_first"]["python_calls"] == 1 and out["after_first"]["pending"] == 1
    assert out["after_second"]["python_calls"] == 1 and out["after_second"]["compiled"] == 1  # the second call ran compiled
    assert list(cache.rglob("*.nbi")) and list(cache.rglob("*.nbc"))  # numba's index and code files, per machine
    again = _child(HYPOT, cache)  # a later process loads the cache (in the background too)
    assert again["second"] == out["first"]


BUFFERED_MODULE = r"""
import numpy as np
from opends_gym.jit import kernel, python_buffers


@python_buffers
@kernel
def scale_then_ratio(a: np.ndarray, pair: tuple) -> float:
    a[0, 1] = a[0, 0] * pair[0][1]  # written through to the caller's array
    return a[0, 0] / pair[1][0]
"""

BUFFERED = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from opends_gym import jit
from buffered_kernel import scale_then_ratio


def call(divisor):
    a = np.array([[3.0, 0.0]])
    try:
        value = scale_then_ratio(a, (np.array([1.0, 2.5]), np.array([divisor])))
    except ZeroDivisionError:
        value = "ZeroDivisionError"
    return [value, a.tolist()]


cold = [call(4.0), call(0.0), jit.compile_status()]
jit.wait_compiled()
print(json.dumps({"cold": cold, "warm": [call(4.0), call(0.0), jit.compile_status()]}))
"""


def test_a_buffered_kernel_run_as_python_writes_and_fails_as_the_compiled_one(tmp_path: Path) -> None:
    """`jit.python_buffers`: the cold run indexes memoryviews (Python floats), so it writes into
    the caller's arrays and a division by zero raises, both as the compiled kernel does (numpy
    scalars would have given inf)."""
    (tmp_path / "buffered_kernel.py").write_text(BUFFERED_MODULE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT), "OPENDS_GYM_JIT_BACKGROUND": "1"}
    done = subprocess.run([sys.executable, "-c", BUFFERED, str(tmp_path)], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    *cold, cold_status = out["cold"]
    *warm, warm_status = out["warm"]
    assert (
        cold_status["python_calls"] == 2 and warm_status["python_calls"] == 2 and warm_status["compiled"] >= 1
    )  # ran as Python, then compiled
    assert cold == warm == [[0.75, [[3.0, 7.5]]], ["ZeroDivisionError", [[3.0, 7.5]]]]


PARALLEL_MODULE = r"""
import numpy as np
from numba import prange
from opends_gym.jit import kernel, parallel_kernel, whole_batch


@parallel_kernel
def chunk_sums(a: np.ndarray) -> float:
    sums = np.zeros(4)
    for j in prange(4):
        for i in range(j, len(a), 4):
            sums[j] += a[i]
    return sums.sum()


@whole_batch
@kernel
def batch_max(a: np.ndarray) -> float:
    return a.max()


@kernel
def single_min(a: np.ndarray) -> float:
    return a.min()
"""

PARALLEL_CALL = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from opends_gym import jit
from parallel_module import batch_max, chunk_sums, single_min
a = np.arange(10.0)
if sys.argv[2] == "fill":
    with jit.compile_in_call():
        chunk_sums(a), batch_max(a), single_min(a)
value = chunk_sums(a) + batch_max(a) + single_min(a)
print(json.dumps({"value": value, **jit.compile_status(), **{"cache_" + k: v for k, v in jit.cache_stats().items()}}))
"""


def test_a_whole_batch_kernel_in_the_cache_loads_in_its_first_call(tmp_path: Path) -> None:
    """A native batch's `parallel_kernel`s and `whole_batch` kernels run as Python for a whole
    step of thousands of envs (seconds): a process whose cache holds their code loads them in
    the first call instead; other kernels (a single env's: milliseconds as Python) and an
    empty cache keep the background path."""
    (tmp_path / "parallel_module.py").write_text(PARALLEL_MODULE)

    def run(cache: Path, mode: str) -> dict:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT), "OPENDS_GYM_JIT_BACKGROUND": "1"}
        done = subprocess.run(
            [sys.executable, "-c", PARALLEL_CALL, str(tmp_path), mode], capture_output=True, text=True, env=env, timeout=300
        )
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.strip().splitlines()[-1])

    cold = run(tmp_path / "empty", "call")
    assert cold["value"] == 54.0 and cold["python_calls"] == 3  # all ran as Python
    filled = run(tmp_path / "cache", "fill")
    assert filled["cache_compiled"] == 3
    warm = run(tmp_path / "cache", "call")  # the two batch kernels loaded in the call, the single env's as Python
    assert warm["value"] == 54.0 and warm["python_calls"] == 1 and warm["cache_loaded"] == 2 and warm["cache_compiled"] == 0
    for code in (tmp_path / "cache").rglob("*.nbc"):  # an index whose code file is gone: not a compile in the call
        code.unlink()
    lost = run(tmp_path / "cache", "call")
    assert lost["value"] == 54.0 and lost["python_calls"] == 3 and lost["cache_compiled"] == 0


def test_a_forked_child_compiles_on_its_own_thread(tmp_path: Path) -> None:
    """The native batch forks its shard workers: a child must not wait on the parent's
    queue (it has no thread to serve it) nor on a compile lock held by the parent's."""
    assert _child(FORK, tmp_path / "cache") == {"child": 0}


def test_background_off_compiles_in_the_first_call(tmp_path: Path) -> None:
    code = "import json\nfrom opends_gym import jit\njit.py_hypot(3.0, 4.0)\nprint(json.dumps(jit.compile_status()))"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT), "OPENDS_GYM_JIT_BACKGROUND": "0"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == {"python_calls": 0, "compiled": 0, "pending": 0}
    assert list(tmp_path.rglob("*.nbi"))


STDOUT_KEPT = r"""
import io, json, sys, threading
import numba
import opends_gym.jit

def bad(x):
    return x + "a"

def compile_bad():  # numba formats a typing error for each: where colorama is installed it coloured them
    for _ in range(12):
        try:
            numba.njit(bad)(1)
        except numba.core.errors.TypingError:
            pass

mine = io.StringIO()
sys.stdout = mine
seen = set()
worker = threading.Thread(target=compile_bad)
worker.start()
while worker.is_alive():
    seen.add(type(sys.stdout).__name__)
worker.join()
seen.add(type(sys.stdout).__name__)
sys.stdout = sys.__stdout__
print(json.dumps({"seen": sorted(seen)}))
"""


def test_a_compile_in_another_thread_leaves_the_programs_stdout_alone(tmp_path: Path) -> None:
    # numba's colouring of error text went through colorama's init/deinit, which swapped
    # sys.stdout process-wide from the compiling thread: output redirected meanwhile (a capture,
    # a session transcript) went to the old stream. Importing opends_gym.jit switches that off.
    assert _child(STDOUT_KEPT, tmp_path / "cache")["seen"] == ["StringIO"]
