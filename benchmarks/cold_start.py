"""Cold start: time to the first step of every registered env with an empty numba cache.

    python benchmarks/cold_start.py                  # every env id, plus two corpus tasks
    python benchmarks/cold_start.py --ids OpenDS/LaneChangeTest-v0 --steps 100

For each env, a fresh Python process with an empty `NUMBA_CACHE_DIR` (as after a fresh
install: no compiled kernel anywhere) imports opends_gym, makes the env, resets it and steps
it; a second process with the cache the first one left (it waits for its background compiles
before it ends) does the same ("warm"). Printed per env and run: import s, make+reset s, first step
s, the slowest of the next `--steps` steps (a later freeze would show there), and how many
kernel calls ran as Python while their compile was pending (`opends_gym.jit.compile_status`).
`--sync` sets OPENDS_GYM_JIT_BACKGROUND=0: the compile-on-first-call behaviour, for comparison.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "data" / "opends-tasks"
TASKS = {  # corpus tasks on the generic env: traffic (41 cars, triggers) and an OpenDRIVE map
    "MotorwayTask": CORPUS / "opends-cts" / "MotorwayTask",
    "init_drive (OpenDRIVE)": CORPUS / "opends2023-annegretj" / "init_drive",
}

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import gymnasium as gym
import numpy as np
import opends_gym
from opends_gym import jit
t1 = time.perf_counter()
env = gym.make(sys.argv[1], **json.loads(sys.argv[2]))
env.reset(seed=0)
t2 = time.perf_counter()
action = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)
env.step(action)
t3 = time.perf_counter()
slowest = 0.0
for _ in range(int(sys.argv[3])):
    t = time.perf_counter()
    _, _, terminated, truncated, _ = env.step(action)
    slowest = max(slowest, time.perf_counter() - t)
    if terminated or truncated:
        env.reset(seed=1)
times = {"import_s": t1 - t0, "make_reset_s": t2 - t1, "first_step_s": t3 - t2, "slowest_later_s": slowest}
print(json.dumps({**times, **jit.compile_status()}), flush=True)
jit.wait_compiled()  # (so that the warm run finds every kernel in the cache; a program would leave them to the compile child)
"""


def measure(env_id: str, kwargs: dict[str, str], cache: Path, steps: int, sync: bool) -> dict[str, float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    if sync:
        env["OPENDS_GYM_JIT_BACKGROUND"] = "0"
    command = [sys.executable, "-c", CHILD, env_id, json.dumps(kwargs), str(steps)]
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
    if done.returncode != 0:
        raise SystemExit(f"{env_id}: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    import opends_gym  # noqa: F401
    from opends_gym.envs import ENVS

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ids", nargs="+", default=None, help="env ids (default: every registered id and the corpus tasks)")
    p.add_argument("--steps", type=int, default=50, help="steps after the first one, for the slowest later step")
    p.add_argument("--sync", action="store_true", help="OPENDS_GYM_JIT_BACKGROUND=0: compile in the first call, as before")
    args = p.parse_args()
    targets: list[tuple[str, str, dict[str, str]]] = [(i, i, {}) for i in (args.ids or sorted(ENVS))]
    if args.ids is None:
        targets += [(name, "OpenDS/DrivingTask-v0", {"task": str(path)}) for name, path in TASKS.items()]
    print(f"{'env':<34} {'run':<5} {'import s':>9} {'make+reset s':>13} {'first step s':>13} {'slowest later s':>16} {'python calls':>13}")
    for name, env_id, kwargs in targets:
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
            for run in ("cold", "warm"):
                r = measure(env_id, kwargs, Path(cache), args.steps, args.sync)
                print(
                    f"{name:<34} {run:<5} {r['import_s']:>9.2f} {r['make_reset_s']:>13.2f} {r['first_step_s']:>13.3f} "
                    f"{r['slowest_later_s']:>16.3f} {r['python_calls']:>13}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
