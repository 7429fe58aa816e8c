"""A native batch's rate, CPU and memory over time, window by window, to its steady state.

Why: a few seconds after a reset a batch with metrics has scored only short episodes and
its trace ring is still growing; later the episodes that end are as long as they get (the
LCT's limit is 300 s, the brake and platoon tests' 600 s), each scored at its end, and the
ring stops growing once the oldest running episode began after the first block still held.
`throughput.py --native` times a few seconds after a short warm-up; this prints each
window's env-steps/s, CPU (user and system, % of a core), minor page faults per step,
episodes ended and the peak resident size, then the rate over the last half of the windows
(the steady state's, once the first half covers the longest episode). A window ends at the
first step after its time is up, so a window that holds a step on which many episodes end
together (the lane follower's, every ~1,930 steps) lasts longer; the last half's rate counts
every step.

    python benchmarks/steady_state.py [--task LaneChangeTest] [--envs 4096] [--windows 12] [--seconds 2]
        [--driver random|keeper] [--no-metrics]

`keeper`: the LCT's lane-following driver (`throughput.lane_keeping`), whose episodes run
the whole track and end together; `random`: random actions (the action space's, 16 drawn
once), whose episodes end at random times.
"""

from __future__ import annotations

import argparse
import resource
import time
from typing import Any

import gymnasium as gym
import numpy as np
from throughput import NATIVE_TASKS, lane_keeping

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.jit import wait_compiled


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", choices=NATIVE_TASKS, default="LaneChangeTest")
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--windows", type=int, default=12)
    ap.add_argument("--seconds", type=float, default=2.0, help="wall seconds per window")
    ap.add_argument("--driver", choices=("random", "keeper"), default="random")
    ap.add_argument("--no-metrics", action="store_true", help="record_metrics=False")
    args = ap.parse_args()
    if args.driver == "keeper" and args.task != "LaneChangeTest":
        raise SystemExit("--driver keeper drives the LaneChangeTest only")
    n, metrics = args.envs, not args.no_metrics
    vec: Any = gym.make_vec(f"OpenDS/{args.task}-v0", num_envs=n, vectorization_mode="vector_entry_point", record_metrics=metrics)
    obs, _ = vec.reset(seed=0)
    vec.action_space.seed(0)
    actions = [vec.action_space.sample() for _ in range(16)]
    step = 0

    def one() -> int:
        nonlocal obs, step
        a = lane_keeping(obs) if args.driver == "keeper" else actions[step % 16]
        obs, _, term, trunc, _ = vec.step(a)
        step += 1
        return int(np.count_nonzero(term | trunc))

    for _ in range(20):
        one()
    wait_compiled()  # (kernels still loading from the cache run as Python meanwhile)
    print(f"{args.task}, {n:,} envs, {args.driver} driver, metrics {'on' if metrics else 'off'}, windows of {args.seconds:g} s")
    print()
    print("| window | policy steps so far | env-steps/s | user % | system % | minor faults / step | episodes ended | peak resident MB |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    half = args.windows // 2  # (the summary: the windows from this one on)
    tail = [0.0, 0.0, 0]  # wall s, CPU s, policy steps
    for w in range(args.windows):
        r0, t0, s0, ended = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter(), step, 0
        while time.perf_counter() - t0 < args.seconds:
            ended += one()
        wall, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_SELF)
        steps = step - s0
        print(f"| {w} | {step:,} | {steps * n / wall:,.0f} | {100 * (r1.ru_utime - r0.ru_utime) / wall:.0f} | "
              f"{100 * (r1.ru_stime - r0.ru_stime) / wall:.0f} | {(r1.ru_minflt - r0.ru_minflt) / steps:.0f} | {ended:,} | "
              f"{r1.ru_maxrss / 1024:,.0f} |", flush=True)  # fmt: skip
        if w >= half:
            cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
            tail[0], tail[1], tail[2] = tail[0] + wall, tail[1] + cpu, tail[2] + steps
    print()
    wall_s, cpu_s, steps_done = tail
    print(f"windows {half}-{args.windows - 1} together: {steps_done * n / wall_s:,.0f} env-steps/s, {100 * cpu_s / wall_s:.0f} % of a core "
          f"({steps_done * n / cpu_s:,.0f} env-steps per CPU s)")  # fmt: skip
    vec.close()


if __name__ == "__main__":
    main()
