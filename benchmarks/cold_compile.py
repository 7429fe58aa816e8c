"""Compile ahead: `opends-gym compile` into an empty numba cache ("cold", as after a fresh
install), again into the cache it filled ("warm"), then the first steps of each native batch
in a new process with that cache (`cold_native.py`), which should compile nothing.

    python benchmarks/cold_compile.py                   # every group; native batches of 4,096 envs
    python benchmarks/cold_compile.py --num-envs 1024 --jobs 2

The native DrivingTask batch is timed on the corpus's MotorwayTask (41 cars; at most 1,024
envs: 4,096 envs' episode traces need 14 GiB), a task the compile step never drove (it
drives a traffic task made from the bundled platoon task).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MOTORWAY = ROOT / "tests" / "data" / "opends-tasks" / "opends-cts" / "MotorwayTask"
BATCHES: list[tuple[str, int | None, list[str]]] = [  # id, most envs, options
    ("OpenDS/LaneChangeTest-v0", None, []),
    ("OpenDS/BrakeReaction-v0", None, []),
    ("OpenDS/ThreeVehiclePlatoon-v0", None, []),
    ("OpenDS/DrivingTask-v0", 1024, ["--task", str(MOTORWAY)]),
]


def _run(command: list[str], cache: Path) -> tuple[float, str]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=3600)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stdout}{done.stderr}")
    return time.perf_counter() - start, done.stdout


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--num-envs", type=int, default=4096)
    p.add_argument("--jobs", type=int, default=None, help="opends-gym compile's worker processes (default: one per core)")
    args = p.parse_args()
    compile_cmd = [sys.executable, "-m", "opends_gym.cli.main", "compile"] + (["--jobs", str(args.jobs)] if args.jobs else [])
    with tempfile.TemporaryDirectory(prefix="numba-aot-") as tmp:
        cache = Path(tmp)
        for run in ("cold", "warm"):
            seconds, out = _run(compile_cmd, cache)
            print(f"## opends-gym compile, {run} cache: {seconds:.1f} s wall (the command itself included)\n\n{out}", flush=True)
        print("| batch | envs | import s | make_vec+reset s | first step s | slowest later s | kernels compiled | loaded | python calls |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for env_id, most, extra in BATCHES:
            n = min(args.num_envs, most or args.num_envs)
            _, out = _run([sys.executable, str(ROOT / "benchmarks" / "cold_native.py"), env_id, str(n), *extra], cache)
            print(out.strip().splitlines()[-1], flush=True)


if __name__ == "__main__":
    main()
