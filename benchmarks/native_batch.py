"""Throughput of the native vector envs over the batch size N (env-steps = policy steps).

    python benchmarks/native_batch.py                       # LCT, N = 1 ... 16384
    python benchmarks/native_batch.py --env platoon --sizes 64 1024 --seconds 5
    python benchmarks/native_batch.py --no-metrics          # without the per-step traces
    python benchmarks/native_batch.py --sizes 4096 --processes 2   # shards in 2 worker processes
    python benchmarks/native_batch.py --sizes 4096 --episode       # one whole LCT episode, scoring included
    python benchmarks/native_batch.py --sizes 4096 --random        # random actions (autoresets), as throughput.py

A lane-keeping policy (the instructed lane for the LCT) keeps the episodes long; the
first steps are not timed (warm-up). Prints one row per N: env-steps per second, ms per
batched step, and the same for Gymnasium's SyncVectorEnv of single envs at the smallest N
for comparison. The timed window ends before the LCT's episodes do (~1,940 steps). With
`--episode` each batch instead drives one whole episode from reset to the end of the track
and reports the rate over all of it, with the step where every env's episode ends and is
scored (`episode_metrics`, unless --no-metrics) on its own.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401
from opends_gym.jit import wait_compiled

IDS = {"lct": "OpenDS/LaneChangeTest-v0", "brake": "OpenDS/BrakeReaction-v0", "platoon": "OpenDS/ThreeVehiclePlatoon-v0"}


def policy(obs: np.ndarray, width: int, lct: bool) -> np.ndarray:
    a = np.zeros((len(obs), width), dtype=np.float32)
    if lct:
        a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
    else:
        a[:, 0] = np.clip(-0.05 * obs[:, 2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
        a[:, 1] = np.clip(0.4 * (19.4 - obs[:, 0]), -1, 1)
    return a


def action_width(env: gym.vector.VectorEnv) -> int:
    shape = env.single_action_space.shape
    assert shape is not None
    return int(shape[0])


def measure(env: gym.vector.VectorEnv, seconds: float, lct: bool, random: bool = False) -> tuple[float, float]:
    width = action_width(env)
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    drawn = [env.action_space.sample() for _ in range(16)] if random else []

    def act(obs: np.ndarray, i: int) -> np.ndarray:
        return drawn[i % 16] if random else policy(obs, width, lct)

    for i in range(3):
        obs, *_ = env.step(act(obs, i))
    wait_compiled()  # (kernels still loading from the cache run as Python meanwhile: not the rate to measure)
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        obs, *_ = env.step(act(obs, steps))
        steps += 1
    dt = time.perf_counter() - t0
    return steps * env.num_envs / dt, 1000.0 * dt / steps


def whole_episode(env: gym.vector.VectorEnv, lct: bool) -> tuple[float, int, float]:
    """Reset, then step until every env's episode has ended once: (env-steps per second over
    it all, steps, seconds of the slowest step: the one that scores the episodes)."""
    width = action_width(env)
    obs, _ = env.reset(seed=0)
    ended = np.zeros(env.num_envs, dtype=bool)
    steps, slowest, t0 = 0, 0.0, time.perf_counter()
    while not ended.all():
        t1 = time.perf_counter()
        obs, _, terminated, truncated, _ = env.step(policy(obs, width, lct))
        slowest = max(slowest, time.perf_counter() - t1)
        ended |= terminated | truncated
        steps += 1
    return steps * env.num_envs / (time.perf_counter() - t0), steps, slowest


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", choices=sorted(IDS), default="lct")
    p.add_argument("--sizes", type=int, nargs="+", default=[1, 16, 256, 1024, 4096, 16384])
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--no-metrics", action="store_true", help="record_metrics=False (no traces, no episode_metrics)")
    p.add_argument("--episode", action="store_true", help="one whole episode per batch size, its end (scoring) included")
    p.add_argument("--random", action="store_true", help="random actions (action_space.sample, autoresets) instead of the lane keeper")
    shards = p.add_mutually_exclusive_group()
    shards.add_argument("--threads", type=int, help="shards stepped in this many threads (default: one per core from 2048 envs)")
    shards.add_argument("--processes", type=int, help="shards in this many worker processes")
    args = p.parse_args()
    sharding = {k: v for k, v in (("threads", args.threads), ("processes", args.processes)) if v is not None}
    env_id, lct = IDS[args.env], args.env == "lct"
    print(f"{env_id}, fast backend, 10 Hz policy / 60 Hz physics, record_metrics={not args.no_metrics}, shards: {sharding or 'default'}")
    print(f"{'mode':<8} {'N':>7} {'env-steps/s':>14} {'ms/step':>10}")
    sync = gym.make_vec(env_id, num_envs=min(args.sizes), vectorization_mode="sync")
    rate, ms = measure(sync, min(args.seconds, 5.0), lct, args.random)
    print(f"{'sync':<8} {sync.num_envs:>7} {rate:>14,.0f} {ms:>10.2f}", flush=True)
    sync.close()
    if args.episode:
        print(f"{'mode':<8} {'N':>7} {'env-steps/s':>14} {'steps':>7} {'slowest step s':>15}  (one whole episode)")
    for n in args.sizes:
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=not args.no_metrics, **sharding)
        if args.episode:
            rate, steps, slowest = whole_episode(env, lct)
            print(f"{'native':<8} {n:>7} {rate:>14,.0f} {steps:>7} {slowest:>15.2f}", flush=True)
        else:
            rate, ms = measure(env, args.seconds, lct, args.random)
            print(f"{'native':<8} {n:>7} {rate:>14,.0f} {ms:>10.2f}", flush=True)
        env.close()


if __name__ == "__main__":
    main()
