"""The native batch's threads (`opends_gym.jit.start_threads`, `jit.parallel_allowed`).

The batch steps on numba's GNU OpenMP layer where numba has it, with a short spin set only
while numba loads it; the user's own layer and OpenMP settings win; a process forked from
one that stepped a batch on OpenMP steps its batches serially (OpenMP would end it at its
first parallel region), with the same results. Each case runs in a fresh interpreter: numba
loads one threading layer per process.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys

THREAD_SETTINGS = ("NUMBA_THREADING_LAYER", "NUMBA_THREADING_LAYER_PRIORITY", "GOMP_SPINCOUNT", "OMP_WAIT_POLICY")  # (the user's choices)


def _has_openmp() -> bool:
    """Whether numba's OpenMP layer loads here (its library needs the system's libgomp)."""
    try:
        importlib.import_module("numba.np.ufunc.omppool")
    except ImportError:
        return False
    return True


HAS_OPENMP = _has_openmp()

STEP_BATCH = r"""
import json, logging, os, sys, warnings
logging.disable(logging.WARNING); warnings.simplefilter("ignore")
import gymnasium as gym, numba, numpy as np
import opends_gym  # noqa: F401
vec = gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=512, vectorization_mode="vector_entry_point", record_metrics=False)
vec.reset(seed=3)
for _ in range(3):
    vec.step(np.full((512, 2), 0.2))
core = vec.unwrapped.shards[0].core
print(json.dumps({"layer": numba.threading_layer(), "parallel": core.parallel,
                  "env": {k: os.environ.get(k) for k in ("GOMP_SPINCOUNT", "OMP_WAIT_POLICY")}}))
"""


def _run(code: str, **env: str) -> dict[str, object]:
    clean = {k: v for k, v in os.environ.items() if k not in THREAD_SETTINGS}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=clean | env, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_native_batch_steps_on_openmp_and_leaves_the_environment_as_it_was() -> None:
    out = _run(STEP_BATCH)
    assert out["layer"] == ("omp" if HAS_OPENMP else "workqueue")
    assert out["parallel"] is True
    assert out["env"] == {"GOMP_SPINCOUNT": None, "OMP_WAIT_POLICY": None}  # (set only while numba loaded the layer)


def test_the_users_threading_layer_and_openmp_settings_win() -> None:
    assert _run(STEP_BATCH, NUMBA_THREADING_LAYER="workqueue")["layer"] == "workqueue"
    assert _run(STEP_BATCH, NUMBA_THREADING_LAYER_PRIORITY="workqueue omp tbb")["layer"] == "workqueue"
    out = _run(STEP_BATCH, OMP_WAIT_POLICY="ACTIVE")
    assert out["env"] == {"GOMP_SPINCOUNT": None, "OMP_WAIT_POLICY": "ACTIVE"}


FORK = r"""
import json, logging, os, warnings
logging.disable(logging.WARNING); warnings.simplefilter("ignore")
import gymnasium as gym, numpy as np
import opends_gym  # noqa: F401
from opends_gym.jit import parallel_allowed, wait_compiled

N = 512
actions = np.random.default_rng(0).uniform(-1, 1, (8, N, 2))

def run(vec):
    vec.reset(seed=11)
    for a in actions:
        obs = vec.step(a)[0]
    return float(np.asarray(obs, dtype=np.float64).sum())

def make():
    return gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=N, vectorization_mode="vector_entry_point", record_metrics=False)

made_before = make()
run(made_before)
wait_compiled()  # (the parent enters OpenMP's parallel regions: its kernels are compiled, not their Python twins)
parent = run(make())
read, write = os.pipe()
pid = os.fork()
if pid == 0:  # the child: a batch made before the fork and a new one, stepped here
    os.close(read)
    out = {"allowed": parallel_allowed(), "old": run(made_before), "new": run(make()),
           "parallel": made_before.unwrapped.shards[0].core.parallel}
    os.write(write, json.dumps(out).encode())
    os._exit(0)
os.close(write)
got = b""
while chunk := os.read(read, 65536):
    got += chunk
_, status = os.waitpid(pid, 0)
print(json.dumps({"status": status, "parent": parent, "child": json.loads(got) if got else None}))
"""


def test_a_process_forked_after_openmp_steps_its_batches_serially_with_the_same_results() -> None:
    out = _run(FORK)
    assert out["status"] == 0, "the forked child ended abnormally (OpenMP's fork check)"
    child = out["child"]
    assert isinstance(child, dict)
    assert child["allowed"] is (not HAS_OPENMP)  # (workqueue, the fallback, survives a fork)
    assert child["parallel"] is (not HAS_OPENMP)
    assert child["old"] == child["new"] == out["parent"]
