"""How does a native batch (the Lane Change Test's unless `--env`) scale over cores? One table: 1, 2, 4, 8, 16 threads.

Each measurement runs in a fresh process with `NUMBA_NUM_THREADS=k` (the step kernels' chunks
of envs run on numba's k threads) and `--envs-per-thread` envs per thread (2,048 by default:
the batch grows with the threads, as a trainer would size it), random actions with resets,
with and without the per-step traces (`record_metrics`). The thread counts run in
interleaved rounds (1, 2, 4, ... then again) so that a shared host's drift spreads over all
of them; the table gives each count's median and range over the rounds, the speed-up over
one thread and `cpu %` (the process's CPU time over wall time: below k x 100 %, other
programs had the cores or the threads waited) and the rate per CPU second (what the
threads computed while they ran; the steadiest figure on a busy host). Thread counts above this host's cores are
measured too (marked: they share the cores) unless `--threads` leaves them out.

    python benchmarks/scaling.py [--env OpenDS/LaneChangeTest-v0] [--threads 1 2 4 8 16] [--envs-per-thread 2048]
                                 [--seconds 3] [--rounds 3] [--processes]

`--processes` runs the same counts as the batch's `processes=k` worker processes of one
thread each: the Python glue of each step then runs in k processes, not one.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

PROBE = """
import json, sys, time, logging
import gymnasium as gym, numba
import opends_gym
from opends_gym.jit import wait_compiled
logging.disable(logging.WARNING)
n, seconds, metrics, procs, env_id = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == "1", int(sys.argv[4]), sys.argv[5]
shards = {"processes": procs} if procs > 1 else {}
env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=metrics, **shards)
env.reset(seed=0)
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range(16)]
for i in range(5):
    env.step(actions[i % 16])
wait_compiled()  # (kernels still loading from the cache run as Python meanwhile: not the rate to measure)
for i in range(5):
    env.step(actions[i % 16])
steps, t0, c0 = 0, time.perf_counter(), time.process_time()
while time.perf_counter() - t0 < seconds:
    env.step(actions[steps % 16])
    steps += 1
wall = time.perf_counter() - t0
print(json.dumps({"rate": steps * n / wall, "cpu": (time.process_time() - c0) / wall, "threads": numba.get_num_threads()}))
"""


def probe(
    threads: int, envs: int, seconds: float, metrics: bool, processes: bool = False, env_id: str = "OpenDS/LaneChangeTest-v0"
) -> dict[str, float]:
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    argv = [str(envs), str(seconds), "1" if metrics else "0", str(threads if processes else 1), env_id]
    out = subprocess.run([sys.executable, "-c", PROBE, *argv], env=env, capture_output=True, text=True)
    if out.returncode != 0:  # one failed size (out of memory, say) must not lose the table: say why and go on
        lines = out.stderr.strip().splitlines() or [f"exit status {out.returncode}"]
        raise RuntimeError(lines[-1])
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--env", default="OpenDS/LaneChangeTest-v0", help="a native batch's env id (LaneChangeTest, BrakeReaction, ThreeVehiclePlatoon)"
    )
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    ap.add_argument("--envs-per-thread", type=int, default=2048)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--processes", action="store_true", help="k one-thread workers (processes=k), not k threads; cpu %% = the parent only")
    args = ap.parse_args()
    cores = os.cpu_count() or 1
    unit = "processes (one thread each)" if args.processes else "threads"
    print(f"native {args.env}, {unit}, random actions with resets, {args.envs_per_thread} envs per thread, {cores} cores here, "
          f"{args.rounds} interleaved rounds of {args.seconds:.1f} s; {time.strftime('%Y-%m-%d %H:%M')}", flush=True)  # fmt: skip
    results: dict[tuple[int, bool], list[dict[str, float]]] = {}
    for r in range(args.rounds):
        for k in args.threads:
            for metrics in (False, True):
                try:
                    res = probe(k, k * args.envs_per_thread, args.seconds, metrics, args.processes, args.env)
                except RuntimeError as err:
                    print(f"round {r + 1}: {k} threads, metrics {metrics}: failed: {err}", flush=True)
                    continue
                results.setdefault((k, metrics), []).append(res)
                print(f"round {r + 1}: {k} threads, metrics {metrics}: {res['rate']:,.0f} env-steps/s, cpu {100 * res['cpu']:.0f} %",
                      flush=True)  # fmt: skip
    print()
    print("| threads | envs | without metrics: env-steps/s (median, range) | speed-up | cpu % | per CPU s | with metrics: env-steps/s "
          "(median, range) | speed-up | cpu % | per CPU s |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    first = {m: results.get((args.threads[0], m)) for m in (False, True)}
    base = {m: float(np.median([x["rate"] for x in first[m]])) if first[m] else float("nan") for m in (False, True)}
    for k in args.threads:
        cells = [f"{k}{' (> cores)' if k > cores else ''}", f"{k * args.envs_per_thread:,}"]
        for metrics in (False, True):
            if (k, metrics) not in results:
                cells += ["failed (above)", "", "", ""]
                continue
            rates = [x["rate"] for x in results[(k, metrics)]]
            cpu = float(np.median([x["cpu"] for x in results[(k, metrics)]]))
            med = float(np.median(rates))
            per_cpu = float(np.median([x["rate"] / x["cpu"] for x in results[(k, metrics)]]))
            cells += [
                f"{med:,.0f} ({min(rates):,.0f}-{max(rates):,.0f})",
                f"{med / base[metrics]:.2f}x",
                f"{100 * cpu:.0f}",
                f"{per_cpu:,.0f}",
            ]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
