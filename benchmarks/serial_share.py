"""How much of a native LCT step is Python outside its compiled step kernels?

What a many-thread run pays serially shows on one thread with many envs: this times every
call of the LCT batch's step kernels (`lct_step`; before it, `lct_substeps` and
`lct_finish`) with `perf_counter` (no profiler, whose cost per Python call would count as
Python) over `--steps` steps of random actions with resets, no metrics, after 100 untimed
ones, and prints the wall time per step inside those calls (the kernels, numba's argument
unboxing included) and outside them (Python: the env's step, argument tuples, output
arrays, info dict), with the latter's share of the step.

    NUMBA_NUM_THREADS=1 python benchmarks/serial_share.py [--envs 32768] [--steps 60]
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from collections.abc import Callable
from typing import Any

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.vector import lct

KERNELS = ("lct_step", "lct_substeps", "lct_finish")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=32768)
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    n = args.envs
    env = gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=n, vectorization_mode="vector_entry_point", record_metrics=False)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(16)]
    for i in range(100):
        env.step(actions[i % 16])
    inside = [0.0]
    for name in [k for k in KERNELS if hasattr(lct, k)]:
        kernel = getattr(lct, name)

        def timed(*a: Any, _fn: Callable[..., Any] = kernel) -> Any:
            t = time.perf_counter()
            try:
                return _fn(*a)
            finally:
                inside[0] += time.perf_counter() - t

        setattr(lct, name, timed)
    t0 = time.perf_counter()
    for i in range(args.steps):
        env.step(actions[i % 16])
    wall = time.perf_counter() - t0
    outside = wall - inside[0]
    print(f"native LCT, {n:,} envs, NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}, {args.steps} steps: "
          f"{1e3 * wall / args.steps:.2f} ms per step, step kernels {1e3 * inside[0] / args.steps:.2f} ms, "
          f"Python outside them {1e3 * outside / args.steps:.3f} ms ({100 * outside / wall:.2f} %)")  # fmt: skip
    env.close()


if __name__ == "__main__":
    main()
