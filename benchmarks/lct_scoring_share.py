"""CPU and wall time per env-step of the native LCT batch's ended-episode scoring, split into
its parallel compiled pass and the serial rest, and of the `episode_metrics` info arrays.

Why: on many threads, whatever part of the scoring stays serial caps the batch (Amdahl);
one thread with many envs shows that part per env-step, which a 16-thread run pays in full
while the compiled pass divides by the threads. Random actions with resets, metrics on,
after a warm-up (`--warmup` steps) in which episodes start ending. Works on a checkout
before `LctBatch.episodes_table` too (then the whole `episodes_metrics` call is serial).

    NUMBA_NUM_THREADS=1 python benchmarks/lct_scoring_share.py --envs 16384 --steps 100
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.vector import env as vector_env
from opends_gym.vector import lct


def _timed(owner: Any, name: str, acc: dict[str, float]) -> None:
    """Wrap owner.name to add its process CPU and wall seconds into acc[name + ' cpu' / ' wall']."""
    fn: Callable[..., Any] = getattr(owner, name)
    acc[f"{name} cpu"] = acc[f"{name} wall"] = 0.0

    def timed(*a: Any, **kw: Any) -> Any:
        c, w = time.process_time(), time.perf_counter()
        try:
            return fn(*a, **kw)
        finally:
            acc[f"{name} cpu"] += time.process_time() - c
            acc[f"{name} wall"] += time.perf_counter() - w

    setattr(owner, name, timed)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=16384)
    ap.add_argument("--steps", type=int, default=100, help="measured steps")
    ap.add_argument("--warmup", type=int, default=300, help="steps before measuring")
    args = ap.parse_args()
    new = hasattr(lct.LctBatch, "episodes_table")
    acc: dict[str, float] = {}
    score = "episodes_table" if new else "episodes_metrics"
    arrays = "metrics_arrays" if new else "_metrics_arrays"
    _timed(lct.LctBatch, score, acc)
    _timed(vector_env, arrays, acc)
    if new:
        _timed(lct, "lct_score_episodes", acc)
    env: Any = gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=args.envs, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    env.action_space.seed(0)
    acts = [env.action_space.sample() for _ in range(16)]
    for i in range(args.warmup):
        env.step(acts[i % 16])
    for k in acc:
        acc[k] = 0.0
    ends, c0, w0 = 0, time.process_time(), time.perf_counter()
    for i in range(args.steps):
        *_, info = env.step(acts[i % 16])
        ends += int(info["_episode_metrics"].sum()) if "_episode_metrics" in info else 0
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    env.close()
    es = args.steps * args.envs

    def ns(key: str) -> str:
        return f"{acc[key] / es * 1e9:.0f}"

    print(f"{'episodes_table' if new else 'episodes_metrics (before the table)'}: {args.envs:,} envs, {args.steps} steps")
    print(f"  {es / wall:,.0f} env-steps/s wall, {es / cpu:,.0f} per CPU s ({cpu / wall * 100:.0f} % CPU); "
          f"{ends} episodes ended ({ends / es * 1e3:.2f} per 1k env-steps)")  # fmt: skip
    print(f"  scoring ({score}): CPU {ns(score + ' cpu')} ns per env-step ({acc[score + ' cpu'] / max(ends, 1) * 1e6:.0f} µs per "
          f"ended episode), wall {ns(score + ' wall')} ns")  # fmt: skip
    if new:
        serial = (acc[f"{score} wall"] - acc["lct_score_episodes wall"]) / es * 1e9
        print(f"  - parallel pass (lct_score_episodes): CPU {ns('lct_score_episodes cpu')} ns, wall {ns('lct_score_episodes wall')} ns; "
              f"serial rest: wall {serial:.0f} ns")  # fmt: skip
    print(f"  episode_metrics info arrays ({arrays}, serial): CPU {ns(arrays + ' cpu')} ns, wall {ns(arrays + ' wall')} ns")


if __name__ == "__main__":
    main()
