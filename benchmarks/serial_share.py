"""How much of a native batch's step is Python outside its compiled step kernels?

What a many-thread run pays serially shows on one thread with many envs: this times every
call of the batch's step kernels (`KERNELS`: the LCT's `lct_step`, or before it
`lct_substeps` and `lct_finish`; the brake and platoon tests' `platoon_step`, or before it
`platoon_substeps` and `platoon_finish` with the lead measures of a reset) with
`perf_counter` (no profiler, whose cost per Python call would count as Python) over
`--steps` steps of random actions with resets, no metrics, after 100 untimed ones, and
prints the wall time per step inside those calls (the kernels, numba's argument unboxing
included) and outside them (Python: the env's step, argument tuples, output arrays, info
dict, resets done in numpy), with the latter's share of the step.

    NUMBA_NUM_THREADS=1 python benchmarks/serial_share.py [--task LaneChangeTest] [--envs 32768] [--steps 60]
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from collections.abc import Callable
from types import ModuleType
from typing import Any

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.jit import wait_compiled
from opends_gym.vector import lct, platoon

# the step kernels each task's batch module calls (those it has: older versions have others)
_PLATOON = ("platoon_step", "platoon_step_serial", "platoon_substeps", "_substeps_range", "platoon_finish", "_finish_range",
            "lead_measures", "_lead_range", "lead_rows", "reset_envs", "reset_range", "step_controls")  # fmt: skip
KERNELS: dict[str, tuple[ModuleType, tuple[str, ...]]] = {
    "LaneChangeTest": (lct, ("lct_step", "lct_step_serial", "lct_substeps", "lct_finish", "_substeps_range", "_finish_range")),
    "BrakeReaction": (platoon, _PLATOON),
}
KERNELS["ThreeVehiclePlatoon"] = KERNELS["BrakeReaction"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", choices=sorted(KERNELS), default="LaneChangeTest")
    ap.add_argument("--envs", type=int, default=32768)
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    n = args.envs
    env = gym.make_vec(f"OpenDS/{args.task}-v0", num_envs=n, vectorization_mode="vector_entry_point", record_metrics=False)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(16)]
    for i in range(100):
        env.step(actions[i % 16])
    wait_compiled()  # (kernels still loading from the cache run as Python meanwhile)
    inside = [0.0]
    module, names = KERNELS[args.task]
    for name in [k for k in names if hasattr(module, k)]:
        kernel = getattr(module, name)

        def timed(*a: Any, _fn: Callable[..., Any] = kernel) -> Any:
            t = time.perf_counter()
            try:
                return _fn(*a)
            finally:
                inside[0] += time.perf_counter() - t

        setattr(module, name, timed)
    t0 = time.perf_counter()
    for i in range(args.steps):
        env.step(actions[i % 16])
    wall = time.perf_counter() - t0
    outside = wall - inside[0]
    print(f"native {args.task}, {n:,} envs, NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}, {args.steps} steps: "
          f"{1e3 * wall / args.steps:.2f} ms per step, step kernels {1e3 * inside[0] / args.steps:.2f} ms, "
          f"Python outside them {1e3 * outside / args.steps:.3f} ms ({100 * outside / wall:.2f} %, "
          f"{1e9 * outside / args.steps / n:.0f} ns per env-step)")  # fmt: skip
    env.close()


if __name__ == "__main__":
    main()
