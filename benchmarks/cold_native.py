"""Cold first step of a native batch: import, make_vec+reset and the first steps of one native
batch, in this process. Run it with an empty numba cache to see what a fresh install pays:

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/cold_native.py OpenDS/LaneChangeTest-v0 4096

On a cold cache the native batch's kernels run as Python while a child process compiles them
(`opends_gym.jit`), so this measures the steps as Python; after `opends-gym compile` into the
same cache it measures loading them instead (`benchmarks/cold_compile.py` runs both).
`--until-compiled` steps on until every queued compile is done. Printed as a table row: id,
envs, import s, make_vec+reset s, first step s, the slowest of the next steps s, how many
kernels this process compiled and loaded from the cache (`opends_gym.jit.cache_stats`; the
child's compiles count as loaded here), the kernel calls that ran as Python, and with
`--until-compiled` the seconds from the first step until the compiles were done, the steps
run meanwhile and the median step after.
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("env_id")
    ap.add_argument("num_envs", type=int)
    ap.add_argument("--task", help="DrivingTask-v0: the task folder")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--no-metrics", action="store_true", help="record_metrics=False (no episode traces)")
    ap.add_argument("--until-compiled", action="store_true", help="step on until the compiles are done (at most 30 minutes)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    import opends_gym  # noqa: F401  (registers the envs)

    t1 = time.perf_counter()
    kwargs: dict[str, object] = {"task": args.task} if args.task else {}
    if args.no_metrics:
        kwargs["record_metrics"] = False
    env = gym.make_vec(args.env_id, num_envs=args.num_envs, vectorization_mode="vector_entry_point", **kwargs)
    env.reset(seed=0)
    t2 = time.perf_counter()
    rng = np.random.default_rng(0)
    times = []
    for _ in range(args.steps):
        action = rng.uniform(-1, 1, size=env.action_space.shape).astype(np.float32)
        start = time.perf_counter()
        env.step(action)
        times.append(time.perf_counter() - start)
    from opends_gym import jit

    tail = ""
    if args.until_compiled:
        steps, after = len(times), []
        while jit.compile_status()["pending"] and time.perf_counter() - t2 < 1800:
            env.step(rng.uniform(-1, 1, size=env.action_space.shape).astype(np.float32))
            steps += 1
        done = time.perf_counter() - t2
        for _ in range(args.steps):
            action = rng.uniform(-1, 1, size=env.action_space.shape).astype(np.float32)
            start = time.perf_counter()
            env.step(action)
            after.append(time.perf_counter() - start)
        tail = f" {done:.0f} | {steps} | {float(np.median(after)):.3f} |"
    stats, status = jit.cache_stats(), jit.compile_status()
    print(
        f"| {args.env_id} | {args.num_envs} | {t1 - t0:.2f} | {t2 - t1:.2f} | {times[0]:.2f} | {max(times[1:]):.2f} "
        f"| {stats['compiled']} | {stats['loaded']} | {status['python_calls']} |{tail}",
        flush=True,
    )
    os._exit(0)  # (not waiting at exit for compiles still queued: a cold run's child would finish them)


if __name__ == "__main__":
    main()
