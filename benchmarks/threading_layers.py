"""Which numba threading layer and OpenMP wait policy steps the native LCT batch fastest?

Each configuration runs in its own process (numba loads one layer per process), rounds
alternating, with `--busy K` programs spinning beside them (a shared host): `workqueue`;
GNU OpenMP as `opends_gym.jit.start_threads` sets it up when the user chose nothing (its
waiting threads spin 2,000 rounds, a few microseconds, then sleep); OpenMP whose threads
sleep at once; OpenMP spinning longer (`GOMP_SPINCOUNT`).
Per configuration: the wall time of a 4,096-env step (random actions with resets, 2
threads or `--threads`; `throughput.measure_native`'s timing), median and range over the rounds.

    python benchmarks/threading_layers.py [--envs 4096] [--seconds 3] [--rounds 3] [--busy 0] [--metrics]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)  # (the child imports `throughput` from here)
CONFIGS = {  # label: environment
    "workqueue": {"NUMBA_THREADING_LAYER": "workqueue"},
    "OpenMP, GOMP_SPINCOUNT=2000 (the default)": {},
    "OpenMP, OMP_WAIT_POLICY=PASSIVE": {"NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "PASSIVE"},
    "OpenMP, GOMP_SPINCOUNT=20000": {"NUMBA_THREADING_LAYER": "omp", "GOMP_SPINCOUNT": "20000"},
    "OpenMP, GOMP_SPINCOUNT=100000": {"NUMBA_THREADING_LAYER": "omp", "GOMP_SPINCOUNT": "100000"},
}

CHILD = r"""
import logging, sys, warnings
logging.disable(logging.WARNING); warnings.simplefilter("ignore")
import numba
sys.path.insert(0, sys.argv[5])
import throughput as tp  # (its `measure_native`: the same warm-up, wait for the kernels and timing)
n, seconds, metrics, threads = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == "1", int(sys.argv[4])
numba.set_num_threads(threads)
case = next(c for c in tp.opends_cases() if c.label == "LaneChangeTest")
row = tp.measure_native(case, "fast", n, seconds, memory=False, metrics=metrics)
print(numba.threading_layer(), 1e3 * n / row.steps_per_s)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--busy", type=int, default=0, help="programs spinning beside the batch (a shared host)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--metrics", action="store_true")
    args = ap.parse_args()
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
    ms: dict[str, list[float]] = {label: [] for label in CONFIGS}
    layer: dict[str, str] = {}
    try:
        for _ in range(args.rounds):
            for label, env in CONFIGS.items():
                clean = {k: v for k, v in os.environ.items() if k not in ("NUMBA_THREADING_LAYER", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
                argv = [str(args.envs), str(args.seconds), "1" if args.metrics else "0", str(args.threads), HERE]
                out = subprocess.run([sys.executable, "-c", CHILD, *argv], env=clean | env, capture_output=True, text=True, check=True)
                name, value = out.stdout.split()[-2:]
                layer[label] = name
                ms[label].append(float(value))
    finally:
        for p in busy:
            p.kill()
    print(f"\n{args.envs} LCT envs, {args.threads} threads, metrics {'on' if args.metrics else 'off'}, {args.busy} busy programs "
          f"beside, {args.rounds} alternating rounds, {os.cpu_count()} cores")  # fmt: skip
    print("\n| configuration | layer loaded | ms per step, median | range | env-steps/s, median |")
    print("|---|---|---:|---:|---:|")
    for label, values in ms.items():
        med = statistics.median(values)
        print(f"| {label} | {layer[label]} | {med:.2f} | {min(values):.2f}-{max(values):.2f} | {args.envs / med * 1e3:,.0f} |")


if __name__ == "__main__":
    main()
