"""What limits the native Lane Change Test batch? CPU time per env-step, by part, on one thread.

Measures CPU time (this process's, all threads: other programs on a shared host do not
count) per env-step of a native LCT batch (random actions with resets, `NUMBA_NUM_THREADS=1`
unless set) and splits it:

* `ego physics only`: the ego car's model alone (`vector.ego.ego_step_wheels`: cruise
  control, minSpeed, powertrain, four-wheel single-track body), the batch's physics steps
  per policy step, in one compiled loop, random steering and pedals as the random actions':
  the floor for any batch that computes the single env's floats;
* the whole step without and with the per-step traces (`record_metrics`), and from a
  profile of the latter the share of the compiled step kernels (`lct_step`, the one pass
  that checks, resets, steps and finishes; before it `lct_substeps` and `lct_finish`, and
  `lct_outcomes` and `lct_observation`) and of the rest (Python glue, trigger firing,
  episode scoring);
* `--parts`: the step's parts by CPU time (each part's calls timed with `process_time`:
  the compiled physics pass, the finishing pass, action checks and conversion, resets,
  episode scoring, the episode-metrics arrays, the rest), in ns per env-step.

    python benchmarks/native_profile.py [--envs 4096] [--steps 200] [--parts]
"""

from __future__ import annotations

import argparse
import cProfile
import logging
import math
import os
import pstats
import time
from collections.abc import Callable

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401
from opends_gym.jit import borrowing_kernel, wait_compiled
from opends_gym.sim.ego.kernels import wheel_constants
from opends_gym.sim.ego.spec import MAX_WHEEL_ANGLE_RAD
from opends_gym.vector.ego import EgoParams, ego_step_wheels

LCT = "OpenDS/LaneChangeTest-v0"


@borrowing_kernel
def physics_only(car: np.ndarray, dt: float, steps: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray,
                 steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:  # fmt: skip
    """`steps` ego physics steps of every car, its state in registers, without reference
    counting (as `lct_substeps`: a `kernel` would update the car array's count atomically at
    every physics step, a few ns of the ~58 per physics step, 2026-11-27)."""
    for e in range(len(x)):
        xe, ze, ye, ue, ve, re, ge, rpm, pv, fu, fl, con, cint = x[e], z[e], yaw[e], u[e], 0.0, 0.0, 3, 2000.0, u[e], 0.0, 50.0, True, 0.0
        a = steer[e] * MAX_WHEEL_ANGLE_RAD
        ca, sa = math.cos(a), math.sin(a)
        wc = wheel_constants(car, dt, ca, sa)
        for _ in range(steps):
            u0 = ue
            xe, ze, ye, ue, ve, re, ge, rpm, fu, fl, con, cint, _, _, _, _ = ego_step_wheels(
                car, wc, True, False, 0.0, dt, xe, ze, ye, ue, ve, re, ge, rpm, pv, fu, fl, con, ue, cint, ca, sa, gas[e], brake[e]
            )
            pv = u0
        x[e], z[e], yaw[e], u[e] = xe, ze, ye, ue


def timed_parts(parts: dict[str, float]) -> list[tuple[object, str, Callable[..., object]]]:
    """Time the LCT batch's step parts into `parts` (CPU seconds, all threads); returns what
    to put back."""
    from opends_gym.vector import actions, env, lct

    named = [(lct, "lct_step", "one-pass step (lct_step)"), (lct, "lct_step_serial", "one-pass step (lct_step)"),
             (lct, "lct_substeps", "physics pass (lct_substeps)"), (lct, "_substeps_range", "physics pass (lct_substeps)"),
             (lct, "lct_finish", "finishing pass (lct_finish)"), (lct, "_finish_range", "finishing pass (lct_finish)"),
             (actions.BatchActions, "convert", "action checks and conversion"), (env, "_check_actions", "action checks and conversion"),
             (lct.LctBatch, "reset_rows", "resets (BatchCore.reset_rows)"), (lct.LctBatch, "episodes_table", "episode scoring"),
             (env, "metrics_arrays", "episode_metrics arrays"), (env, "_metrics_arrays", "episode_metrics arrays")]  # fmt: skip
    undo = []
    for obj, name, label in named:
        fn = getattr(obj, name)
        undo.append((obj, name, fn))

        def timed(*a: object, _fn: Callable[..., object] = fn, _label: str = label, **kw: object) -> object:
            c = time.process_time()
            try:
                return _fn(*a, **kw)
            finally:
                parts[_label] = parts.get(_label, 0.0) + time.process_time() - c

        setattr(obj, name, timed)
    return undo


def cpu_per_env_step(step: object, n: int, steps: int, parts: dict[str, float] | None = None) -> float:
    """CPU ns per env-step of `steps` calls of step() (after 5 untimed ones; `parts` emptied
    after them)."""
    for _ in range(5):
        step()  # type: ignore[operator]
    if parts is not None:
        parts.clear()
    c0 = time.process_time()
    for _ in range(steps):
        step()  # type: ignore[operator]
    return 1e9 * (time.process_time() - c0) / (steps * n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--parts", action="store_true", help="split each whole step's CPU time by part")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    n = args.envs
    template = gym.make(LCT).unwrapped
    p = EgoParams.from_world(template.world)
    repeat, dt = template.config.action_repeat, template.world.dt_s
    rng = np.random.default_rng(0)
    state = [np.zeros(n), np.zeros(n), np.zeros(n), np.full(n, 22.0)]
    pedal = rng.uniform(-1, 1, n)  # (as the random actions: half the cars brake)
    controls = [rng.uniform(-1, 1, n), np.maximum(pedal, 0.0), np.maximum(-pedal, 0.0)]
    physics_only(p.car, dt, repeat, *[a.copy() for a in state], *controls)
    wait_compiled()  # (a kernel outside the package compiles in the background and runs as Python meanwhile)
    ego_ns = cpu_per_env_step(lambda: physics_only(p.car, dt, repeat, *state, *controls), n, args.steps)
    print(f"native LCT, {n} envs, random actions with resets, NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}; CPU time per env-step:")
    print(f"  ego physics only ({repeat} physics steps)  {ego_ns:8.0f} ns  ({ego_ns / repeat:.0f} ns per physics step)")
    for metrics in (False, True):
        env = gym.make_vec(LCT, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=metrics)
        env.reset(seed=0)
        env.action_space.seed(0)
        actions = [env.action_space.sample() for _ in range(16)]
        i = [0]

        def step(env: gym.vector.VectorEnv = env, actions: list[np.ndarray] = actions, i: list[int] = i) -> None:
            env.step(actions[i[0] % 16])
            i[0] += 1

        parts: dict[str, float] = {}
        undo = timed_parts(parts) if args.parts else []
        ns = cpu_per_env_step(step, n, args.steps, parts)
        for obj, name, fn in undo:
            setattr(obj, name, fn)
        print(f"  whole step, record_metrics={metrics!s:<5}         {ns:8.0f} ns  ({1e9 / ns:,.0f} env-steps per CPU second)")
        for label, seconds in sorted(parts.items(), key=lambda kv: -kv[1]):
            print(f"    {label:<38} {1e9 * seconds / (args.steps * n):8.0f} ns")
        if parts:
            print(f"    {'the rest (Python: env.step, info)':<38} {ns - 1e9 * sum(parts.values()) / (args.steps * n):8.0f} ns")
        if metrics:
            prof = cProfile.Profile()
            prof.runcall(lambda: [step() for _ in range(args.steps)])
            stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
            total = sum(v[2] for v in stats.values())
            names = ("lct_step", "lct_substeps", "lct_outcomes", "lct_observation", "lct_finish")
            kernels = sum(v[2] for (_, _, name), v in stats.items() if name in names)
            share = 100 * kernels / total
            print(f"    compiled step kernels {share:.0f} % of the wall time (cProfile), the rest (Python) {100 - share:.0f} %")
        env.close()


if __name__ == "__main__":
    main()
