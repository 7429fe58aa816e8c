"""Memory of the brake and platoon batches' episode traces over a long run (the trace ring's blocks and spilled rows).

Steps a native batch of `--envs` envs `--steps` random-action steps (with resets, metrics on) and prints, every
`--every` steps, the ring blocks allocated so far, those held and the MB they take (`TraceRing` keeps every block back
to the oldest running episode's first row: it allocates a fresh block, 256 physics steps of every env, for as long as
some env keeps driving, and the compiled step takes a page fault per 4 KB of it; rows spilled out of reused blocks count
where a ring has a `spill`), and over each stretch of `--every` steps the wall time per step, the
page faults per step and the system CPU time per step (`getrusage`: the kernel's share, mostly those faults), after
the background compiles are done.

    python benchmarks/ring_memory.py [--task BrakeReaction] [--envs 4096] [--steps 800] [--every 200]
"""

from __future__ import annotations

import argparse
import logging
import resource
import time

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.jit import wait_compiled
from opends_gym.vector import trace


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default="BrakeReaction")
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--steps", type=int, default=800)
    ap.add_argument("--every", type=int, default=200)
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    fresh = [0]
    make = trace._fresh_block

    def counted(shape: tuple[int, ...]) -> np.ndarray:
        fresh[0] += 1
        return make(shape)

    trace._fresh_block = counted  # type: ignore[assignment]
    vec = gym.make_vec(f"OpenDS/{args.task}-v0", num_envs=args.envs, vectorization_mode="vector_entry_point", record_metrics=True)
    ring = vec.unwrapped.shards[0].core.ring  # type: ignore[attr-defined]
    vec.reset(seed=0)
    vec.action_space.seed(0)
    actions = [vec.action_space.sample() for _ in range(16)]
    vec.step(actions[0])
    wait_compiled()
    print(f"| {args.task}, {args.envs} envs: policy steps | blocks allocated | held | rows spilled | MB (blocks + spill) "
          "| ms per step | page faults per step | system ms per step |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    usage, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    for i in range(1, args.steps + 1):
        vec.step(actions[i % 16])
        if i % args.every == 0:
            now, t1 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
            per = 1.0 / args.every
            block_mb = next(iter(ring.blocks.values())).nbytes / 2**20 if ring.blocks else 0.0
            spill = getattr(ring, "spill", {})
            spilled = sum(len(r) for rows in spill.values() for r in rows)
            mb = block_mb * (len(ring.blocks) + len(ring._spare)) + sum(r.nbytes for rows in spill.values() for r in rows) / 2**20
            faults, system_ms = (now.ru_minflt - usage.ru_minflt) * per, (now.ru_stime - usage.ru_stime) * 1e3 * per
            print(f"| {i} | {fresh[0]} | {len(ring.blocks)} | {spilled} | {mb:,.0f} | {(t1 - t0) * 1e3 * per:.2f} | {faults:.0f} "
                  f"| {system_ms:.2f} |", flush=True)  # fmt: skip
            usage, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    vec.close()


if __name__ == "__main__":
    main()
