"""CPU time of scoring one episode in the native LCT, brake and platoon batches.

Per task: a native batch of `--envs` envs steps `--steps` random actions (with resets),
then `BatchCore.episodes_metrics` scores all its envs' episodes so far, `--calls` times;
prints the median CPU time of the calling thread per episode (other programs on a shared
host do not count). Run it on two checkouts, alternating, to compare scoring code.

    python benchmarks/scoring.py [--envs 1024] [--steps 20] [--calls 7] [--table]
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the envs)

TASKS = ("OpenDS/LaneChangeTest-v0", "OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0")


def scoring_us(env_id: str, n: int, steps: int, calls: int, table: bool = False) -> float:
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=True)
    try:
        core = vec.unwrapped.shards[0].core  # type: ignore[attr-defined]
        vec.reset(seed=0)
        vec.action_space.seed(0)
        actions = [vec.action_space.sample() for _ in range(16)]
        for i in range(steps):
            vec.step(actions[i % 16])
        es = list(range(core.n))
        if table and not hasattr(core, "episodes_table"):
            return float("nan")  # (a checkout before `episodes_table`)
        score = core.episodes_table if table else core.episodes_metrics
        score(es)  # (warm-up: compiles or loads the scoring kernels)
        times = []
        for _ in range(calls):
            t = time.thread_time()
            score(es)
            times.append(1e6 * (time.thread_time() - t) / len(es))
        return statistics.median(times)
    finally:
        vec.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=20, help="random-action steps before scoring")
    ap.add_argument("--calls", type=int, default=7, help="timed scoring calls (the median is printed)")
    ap.add_argument("--table", action="store_true", help="also `episodes_table` (one table, no dict per episode) where a batch has it")
    args = ap.parse_args()
    for env_id in TASKS:
        print(f"{env_id}: {scoring_us(env_id, args.envs, args.steps, args.calls):.1f} CPU µs per episode", flush=True)
        if args.table and env_id != TASKS[0]:  # (the brake and platoon batches: `vector.platoon.PlatoonBatch.episodes_table`)
            us = scoring_us(env_id, args.envs, args.steps, args.calls, table=True)
            print(f"{env_id}: {us:.1f} CPU µs per episode as one table (episodes_table)", flush=True)


if __name__ == "__main__":
    main()
