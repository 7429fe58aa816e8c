"""How much of a native batch's step is Python outside its compiled kernels, and which kernels take the rest?

What a many-thread run pays serially shows on one thread with many envs; what each kernel
loses to threads shows by running it again with k threads and k times the envs. This times
every Python-level call of a compiled kernel (every numba dispatcher in `opends_gym`'s
vector and metrics modules, patched in the module that calls it, after `--warm-steps` untimed steps and
the loads from the cache: compiled code calls its helpers directly, so nothing counts
twice) with `perf_counter` (no profiler, whose cost per Python call would count as Python)
over `--steps` steps of random actions with resets, and prints the wall time per step
inside those calls (numba's argument unboxing included), kernel by kernel, and outside them
(Python: the env's step, argument tuples, output arrays, info dict, resets done in numpy)
and its calls per step (a batch that parks envs for Python calls its pass again for them),
with the latter's share of the step and its ns per env-step. Kernels compiled serially
(no `prange`) are marked: with Python they make the step's serial part, which more threads
do not shorten (the bound printed: Amdahl's law with that part as measured on this run's
threads).

    NUMBA_NUM_THREADS=1 python benchmarks/serial_share.py [--task LaneChangeTest] [--envs 32768] [--steps 60] [--metrics]
        [--warm-steps 100]
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Callable
from typing import Any

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym
from numba.core.dispatcher import Dispatcher

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.jit import wait_compiled

TASKS = ("LaneChangeTest", "BrakeReaction", "ThreeVehiclePlatoon")
PATCHED = ("opends_gym.vector", "opends_gym.metrics")  # the packages whose modules call kernels from Python


def patch_kernels(inside: dict[str, float], parallel: dict[str, bool], calls: dict[str, int]) -> int:
    """Wrap every dispatcher that a vector or metrics module holds as a global so that its
    calls from Python add their wall time to inside[name] and count in calls[name];
    parallel[name]: compiled with `parallel=True`. Returns how many were wrapped."""
    count = 0
    for mod_name, module in list(sys.modules.items()):
        if module is None or not mod_name.startswith(PATCHED):
            continue
        for name, obj in list(vars(module).items()):
            if not isinstance(obj, Dispatcher):
                continue
            inside.setdefault(name, 0.0)
            calls.setdefault(name, 0)
            parallel[name] = bool(obj.targetoptions.get("parallel", False))

            def timed(*a: Any, _fn: Callable[..., Any] = obj, _name: str = name, **kw: Any) -> Any:
                calls[_name] += 1
                t = time.perf_counter()
                try:
                    return _fn(*a, **kw)
                finally:
                    inside[_name] += time.perf_counter() - t

            setattr(module, name, timed)
            count += 1
    return count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", choices=TASKS, default="LaneChangeTest")
    ap.add_argument("--envs", type=int, default=32768)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--metrics", action="store_true", help="with the per-step traces and episode metrics (record_metrics=True)")
    ap.add_argument(
        "--warm-steps",
        type=int,
        default=100,
        help="untimed steps first; past the episode limit (LCT: 3,000) the episodes that end are as long as they get",
    )
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    n = args.envs
    env = gym.make_vec(f"OpenDS/{args.task}-v0", num_envs=n, vectorization_mode="vector_entry_point", record_metrics=args.metrics)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(16)]
    for i in range(args.warm_steps):
        env.step(actions[i % 16])
    wait_compiled()  # (kernels still loading from the cache run as Python meanwhile)
    inside: dict[str, float] = {}
    parallel: dict[str, bool] = {}
    calls: dict[str, int] = {}
    patch_kernels(inside, parallel, calls)
    t0 = time.perf_counter()
    for i in range(args.steps):
        env.step(actions[i % 16])
    wall = time.perf_counter() - t0
    kernels = sum(inside.values())
    outside = wall - kernels
    serial_names = {name for name in inside if not parallel.get(name, False)}
    serial = outside + sum(inside[name] for name in serial_names)
    threads = int(os.environ["NUMBA_NUM_THREADS"])
    ms = 1e3 / args.steps
    print(f"native {args.task}, {n:,} envs, metrics {'on' if args.metrics else 'off'}, NUMBA_NUM_THREADS={threads}, "
          f"{args.steps} steps: {wall * ms:.2f} ms per step, kernels {kernels * ms:.2f} ms, Python outside them {outside * ms:.3f} ms "
          f"({100 * outside / wall:.2f} %, {1e9 * outside / args.steps / n:.0f} ns per env-step)")  # fmt: skip
    share = serial / wall
    print(f"  serial part (Python and serial kernels): {serial * ms:.3f} ms per step, {100 * share:.1f} %: however many threads, "
          f"this step runs at most {1 / share:.0f}x faster than on these {threads} (Amdahl)" if share > 0 else "")  # fmt: skip
    for name, sec in sorted(inside.items(), key=lambda kv: -kv[1]):
        if sec > 0:
            kind = "serial" if name in serial_names else "parallel"
            print(f"  {name:<28} {kind:<8} {sec * ms:8.3f} ms per step ({100 * sec / wall:5.1f} %, "
                  f"{1e9 * sec / args.steps / n:6.0f} ns per env-step, {calls[name] / args.steps:.2f} calls per step)")  # fmt: skip
    env.close()


if __name__ == "__main__":
    main()
