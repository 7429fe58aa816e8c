"""Does an env's memory stay flat over a long run? One env, a million steps, with resets.

Steps one `LaneChangeTest-v0` env (fast backend by default) with random actions, resetting
whenever an episode ends, and prints the resident set size (RSS) every `--every` steps and
its growth since the first report (the warm-up: imports, caches and the first episodes'
buffers). Flat means less than `--tolerance-mb` of growth after the warm-up; the script exits
non-zero otherwise, so a leak (an event log, trace or per-step list that outlives its
episode) fails loudly.

    python benchmarks/soak.py [--steps 1000000] [--every 100000] [--env OpenDS/LaneChangeTest-v0] [--physics fast]
    python benchmarks/soak.py --native 256 --steps 20000 --every 2000   # a native batch of 256 envs, 20,000 batch steps

With `--native N` it steps the native batch (`vector_entry_point`, episode metrics on) of N
envs instead, `--steps` batch steps of random actions with its autoresets; the warm-up then
covers the longest episodes' trace blocks (reused afterwards), so report after it.
"""

from __future__ import annotations

import argparse
import gc
import logging
import sys
import time

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the OpenDS ids)


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return float(line.split()[1]) / 1024.0
    return float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--every", type=int, default=100_000)
    ap.add_argument("--env", default="OpenDS/LaneChangeTest-v0")
    ap.add_argument("--physics", default="fast")
    ap.add_argument("--tolerance-mb", type=float, default=5.0)
    ap.add_argument("--native", type=int, default=0, help="step a native batch of this many envs instead of one env")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    if args.native:
        return soak_native(args)
    env = gym.make(args.env, physics=args.physics)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(4096)]
    every = max(1, min(args.every, args.steps))
    print(f"{args.env} ({args.physics}), {args.steps:,} steps, random actions with resets")
    print(f"{'steps':>10} {'episodes':>9} {'RSS MB':>8} {'growth MB':>10} {'steps/s':>9}")
    first: float | None = None
    rss = float("nan")
    episodes = 0
    t0 = time.perf_counter()
    for i in range(1, args.steps + 1):
        _, _, terminated, truncated, _ = env.step(actions[i % 4096])
        if terminated or truncated:
            episodes += 1
            env.reset()
        if i % every == 0 or i == args.steps:
            gc.collect()
            rss = rss_mb()
            first = rss if first is None else first
            rate = i / (time.perf_counter() - t0)
            print(f"{i:>10,} {episodes:>9,} {rss:>8.1f} {rss - first:>10.1f} {rate:>9,.0f}", flush=True)
    env.close()
    growth = rss - (first if first is not None else rss)
    flat = growth < args.tolerance_mb
    print(f"growth after the first {every:,} steps: {growth:.1f} MB -> {'flat' if flat else 'GROWING'} (tolerance {args.tolerance_mb} MB)")
    return 0 if flat else 1


def soak_native(args: argparse.Namespace) -> int:
    env = gym.make_vec(args.env, num_envs=args.native, vectorization_mode="vector_entry_point", physics=args.physics)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(64)]
    every = max(1, min(args.every, args.steps))
    print(f"{args.env} ({args.physics}), native batch of {args.native} envs, {args.steps:,} batch steps, random actions with autoresets")
    print(f"{'steps':>10} {'episodes':>9} {'RSS MB':>8} {'growth MB':>10} {'env-steps/s':>12}")
    first: float | None = None
    rss = float("nan")
    episodes = 0
    t0 = time.perf_counter()
    for i in range(1, args.steps + 1):
        _, _, terminated, truncated, _ = env.step(actions[i % 64])
        episodes += int((terminated | truncated).sum())
        if i % every == 0 or i == args.steps:
            gc.collect()
            rss = rss_mb()
            first = rss if first is None else first
            rate = i * args.native / (time.perf_counter() - t0)
            print(f"{i:>10,} {episodes:>9,} {rss:>8.1f} {rss - first:>10.1f} {rate:>12,.0f}", flush=True)
    env.close()
    growth = rss - (first if first is not None else rss)
    flat = growth < args.tolerance_mb
    print(f"growth after the first {every:,} steps: {growth:.1f} MB -> {'flat' if flat else 'GROWING'} (tolerance {args.tolerance_mb} MB)")
    return 0 if flat else 1


if __name__ == "__main__":
    sys.exit(main())
