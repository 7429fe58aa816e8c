"""The native brake and platoon batches next to the native LCT's: rate, CPU time, what it goes to.

Per round, for the native LaneChangeTest, BrakeReaction and ThreeVehiclePlatoon batches
(4,096 envs, random actions with resets, metrics on: `throughput.py`'s goal rows, measured
by its own `measure_native`): env-steps per second, this process's CPU share and CPU time
per env-step (comparable on a shared host), and each task's rate as a share of the LCT's.
With `--profile`, one cProfile'd run per task: the episodes that end per env-step, the share
of them that ended with a collision, and the share of the step spent scoring ended episodes (`BatchCore.episodes_metrics`, the single
env's own metric code per episode).

`--parts` (best with `NUMBA_NUM_THREADS=1`) splits the brake and platoon batches' step, without
and with metrics, into CPU ns per env-step by part: the Python-level parts timed by wrappers
around their calls (the compiled physics pass, the finishing pass, resets, trigger firing,
timers, action conversion, episode scoring, the episode-metrics arrays, the rest), and the
compiled pass's pieces each run alone on a copy of the batch's state (ego cars, traffic cars,
`platoon_step.after_one`, the trigger search), with the episodes ended per 1,000 env-steps.

`--motorway N` adds the corpus MotorwayTask (41 road-network traffic cars, trigger boxes) as a
native `OpenDS/DrivingTask-v0` batch of N envs (`opends_gym.vector.driving`), random actions
with resets, without and with metrics (metrics with `max_episode_s=120`, so the traces of
1,024 envs fit in memory: 13 columns x 60 Hz x 120 s x 8 bytes = 0.75 MB per env), next to
its single env (`gymnasium.make`) in the same run, then the CPU time per car of its traffic
kernel alone for 64, 256 and N worlds (a world's own step and its two halves, `advance_carrots`
and `drive`; and the step of the worlds that follow the shared traffic history,
`vector.traffic_history`); `--motorway-only` skips the other tasks.

    python benchmarks/native_tasks.py [--envs 4096] [--seconds 3] [--rounds 3] [--profile] [--parts [--parts-steps 60]]
                                      [--motorway 1024 [--motorway-only]]
"""

from __future__ import annotations

import argparse
import cProfile
import logging
import math
import os
import pstats
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

from opends_gym.jit import borrowing_kernel, wait_compiled
from opends_gym.sim.traffic.motion import step_rows
from opends_gym.vector.kernels import nearest_volume, volume_fires
from opends_gym.vector.platoon_step import after_one
from opends_gym.vector.trace import PLATOON_TRACE_GROUP

sys.path.insert(0, str(Path(__file__).resolve().parent))
import throughput as tp

TASKS = ("LaneChangeTest", "BrakeReaction", "ThreeVehiclePlatoon")
MOTORWAY = str(Path(__file__).resolve().parent.parent / "tests" / "data" / "opends-tasks" / "opends-cts" / "MotorwayTask")


def motorway(n: int, seconds: float, metrics: bool) -> tuple[float, float]:
    """(env-steps per second, CPU ns per env-step) of a native MotorwayTask batch of n envs
    (n = 0: the single env), random actions drawn before timing, resets in the loop."""
    kw: dict[str, object] = {"task": MOTORWAY}
    if n == 0:
        env = gym.make("OpenDS/DrivingTask-v0", **kw)
        env.reset(seed=0)
        env.action_space.seed(0)
        acts = [env.action_space.sample() for _ in range(16)]
        for a in acts:  # its kernels' first calls queue their compiles; time the compiled ones
            env.step(a)
        wait_compiled()
        env.reset(seed=0)

        def step(i: int) -> None:
            _, _, term, trunc, _ = env.step(acts[i % 16])
            if term or trunc:
                env.reset()

        rate, share = tp.timed_steps(step, seconds)
        env.close()
        return rate, 1e9 / (rate / share)
    kw |= {"max_episode_s": 120.0} if metrics else {"record_metrics": False}
    vec = gym.make_vec("OpenDS/DrivingTask-v0", num_envs=n, vectorization_mode="vector_entry_point", **kw)
    vec.reset(seed=0)
    vec.action_space.seed(0)
    actions = [vec.action_space.sample() for _ in range(16)]
    rate, share = tp.timed_steps(lambda i: vec.step(actions[i % 16]), seconds, batch=4)
    vec.close()
    return rate * n, 1e9 / (rate * n / share)


def traffic_kernel_ns(n: int, seconds: float) -> tuple[float, float, float, float]:
    """CPU ns per car and physics step of the batch's traffic kernel alone for n MotorwayTask
    worlds after 50 policy steps of a gentle drive, the same physics step again and again (so
    the cars never reach their routes' ends), serially: (each world's `step_objects`, as the
    batch steps a world whose ego car a traffic car has seen; its two kernels over all worlds
    at once: `advance_carrots`, `drive`; the step of worlds that follow the shared traffic
    history, `driving_step._shared_range`: a safety-box test and a copy per car)."""
    from opends_gym.sim.traffic.motion import advance_carrots, drive
    from opends_gym.vector.driving_step import _shared_range, _worlds_range

    vec = gym.make_vec("OpenDS/DrivingTask-v0", num_envs=n, vectorization_mode="vector_entry_point", task=MOTORWAY, record_metrics=False)
    vec.reset(seed=0)
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 1] = 0.3
    for _ in range(50):
        vec.step(a)
    b = vec.unwrapped.shards[0].core  # type: ignore[attr-defined]
    tr, st = b.traffic, b.traffic.st
    tr.sync(whole=True)  # (the worlds' own rows: those that follow the history keep positions only)
    h = tr.history
    h.extend_to(int(tr.kw.max()) + 1)
    kw = tr.kw.copy()
    t_shared = (kw + 1) * b.dt
    live = np.ones(n, dtype=bool)
    rows = np.ones(n * tr.c, dtype=bool)
    pf, pp, pi = tr.paths.arrays()
    t = b.t.copy()
    state = (st.f, st.i, st.b, st.pos, st.end_xz, tr.work, tr.flags, tr.kw, tr.shared)

    def worlds() -> None:
        _worlds_range(0, n, st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, tr.sp.packed, pf, pp, pi, t, tr.ego, b.dt,
                      tr.work, tr.flags, tr.no_lights, tr.brake, tr.turn, tr.net, tr.quiet, tr.c, live, tr.codes, tr.car_rows)  # fmt: skip

    before_warm = [x.copy() for x in state]
    worlds()  # (the work rows a world that steps itself keeps, its neighbour order above all, as after its first own step)
    for x, v in zip(state, before_warm):
        if x is not tr.work:
            np.copyto(x, v)
    saved = [x.copy() for x in state]

    def shared() -> None:
        _shared_range(0, n, st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, tr.sp.packed, pf, pp, pi, t_shared, tr.ego,
                      b.dt, tr.work, tr.flags, tr.no_lights, tr.brake, tr.turn, tr.net, tr.quiet, tr.c, live, tr.codes, tr.car_rows,
                      tr.shared, tr.kw, h.length, *h.arrays())  # fmt: skip

    def advance() -> None:
        advance_carrots(st.f, st.i, st.b, st.pos, tr.sp.packed, pf, pp, pi, tr.c, rows, t, b.dt, tr.work, tr.flags)

    def driving() -> None:
        drive(st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, tr.sp.packed, pf, pp, pi, tr.c, rows, tr.ego, b.dt, tr.work,
              tr.flags, False, tr.no_lights)  # fmt: skip

    for warm in (worlds, advance, driving, shared):  # (kernels' first calls from Python queue their compiles: time the compiled ones)
        warm()
        for x, v in zip(state, saved):
            np.copyto(x, v)
    wait_compiled()
    out = []
    for before, timed in ((None, worlds), (None, advance), (advance, driving), (None, shared)):
        k, spent = 0, 0.0
        while spent < seconds:
            for x, v in zip(state, saved):
                np.copyto(x, v)
            if before is not None:
                before()
            c0 = time.process_time()
            timed()
            spent += time.process_time() - c0
            k += 1
        out.append(spent / (k * n * tr.c) * 1e9)
    vec.close()
    return out[0], out[1], out[2], out[3]


def motorway_parts(n: int, steps: int) -> None:
    """CPU time per part of the native MotorwayTask batch's policy step (random actions, no
    metrics, after 20 warm-up steps), each part timed by a wrapper around its call (so the
    parts nest: a step's total, its physics steps, their kernels)."""
    from opends_gym.vector import driving, traffic

    spent: dict[str, list[float]] = {}

    def timed(owner: object, name: str, label: str) -> None:
        fn = getattr(owner, name)

        def wrapper(*a: object, **k: object) -> object:
            c0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                cell = spent.setdefault(label, [0.0, 0.0])
                cell[0] += time.process_time() - c0
                cell[1] += 1

        setattr(owner, name, wrapper)

    parts = [(driving.BatchCore, "step_rows", "policy step (all below)"),
             (driving.DrivingTaskBatch, "_physics_step", "physics steps (ego, traffic, contacts, triggers)"),
             (driving, "step_shared", "traffic: worlds following the history (`step_shared`)"),
             (driving.TrafficHistory, "extend_to", "traffic: the history's own world (`extend_to`)"),
             (driving.ego, "step", "ego cars (`ego.step`)"), (driving, "contacts", "contacts with traffic and obstacles"),
             (driving, "_touch_all", "trigger volumes"), (driving.DrivingTaskBatch, "_record_row", "trace rows (lead, route lanes)"),
             (driving.DrivingTaskBatch, "_lead_measures", "lead vehicle, headway, TTC"), (driving, "record_route", "route lanes"),
             (driving.DrivingTaskBatch, "observation", "observation (all below)"), (traffic, "nearest_slots", "nearby-vehicle slots"),
             (driving, "history_rows", "rows synced from the history for the slots")]  # fmt: skip
    saved = [(owner, name, getattr(owner, name)) for owner, name, _ in parts]
    for owner, name, label in parts:
        timed(owner, name, label)
    try:
        vec = gym.make_vec("OpenDS/DrivingTask-v0", num_envs=n, vectorization_mode="vector_entry_point", task=MOTORWAY,
                           record_metrics=False)  # fmt: skip
        vec.reset(seed=0)
        vec.action_space.seed(0)
        actions = [vec.action_space.sample() for _ in range(16)]
        for i in range(20):
            vec.step(actions[i % 16])
        wait_compiled()
        spent.clear()
        c0 = time.process_time()
        for i in range(steps):
            vec.step(actions[i % 16])
        total = time.process_time() - c0
        vec.close()
    finally:
        for owner, name, fn in saved:
            setattr(owner, name, fn)
    per_car = 41 * 6  # cars x physics steps per env-step
    print(f"\n| part ({n} envs, {steps} policy steps) | CPU ns per env-step | per car and physics step |")
    print("|---|---:|---:|")
    print(f"| everything (`vec.step`) | {total / (steps * n) * 1e9:,.0f} | {total / (steps * n * per_car) * 1e9:.1f} |")
    for _, _, label in parts:
        c = spent.get(label, [0.0, 0.0])[0]
        print(f"| {label} | {c / (steps * n) * 1e9:,.0f} | {c / (steps * n * per_car) * 1e9:.1f} |")


def motorway_table(n: int, seconds: float, rounds: int) -> None:
    print("\n| MotorwayTask (41 traffic cars) | env-steps/s: rounds | median | CPU ns per env-step: median | cores busy: median |")
    print("|---|---|---:|---:|---:|")
    for label, envs, metrics in (("single env", 0, True), (f"native, {n} envs, no metrics", n, False),
                                 (f"native, {n} envs, metrics", n, True)):  # fmt: skip
        runs = [motorway(envs, seconds, metrics) for _ in range(rounds)]
        r, c = [x[0] for x in runs], [x[1] for x in runs]
        busy = [x[0] * x[1] / 1e9 for x in runs]  # (CPU seconds per wall second: this process's threads)
        print(f"| {label} | {', '.join(f'{x / 1e3:,.1f}k' for x in r)} | {statistics.median(r) / 1e3:,.1f}k | "
              f"{statistics.median(c):,.0f} | {statistics.median(busy):.2f} |", flush=True)  # fmt: skip


@borrowing_kernel
def _traffic_only(n: int, repeat: int, dt: float, traffic: tuple, t: np.ndarray) -> None:
    """`repeat` traffic steps of every world (`motion.step_rows`, as `platoon_pass` runs them)."""
    f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, ego3, work, flags, stop_mask, brake_out, turn_out, net, quiet, c, rows, \
        codes = traffic  # fmt: skip
    for e in range(n):
        for _ in range(repeat):
            code, _ = step_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego3, dt, work, flags, stop_mask, brake_out,
                                turn_out, net, quiet, c, rows, e * c, (e + 1) * c)  # fmt: skip
            codes[e] = code


@borrowing_kernel
def _after_only(n: int, repeat: int, live: np.ndarray, a: tuple, lead: tuple, lanes: tuple, ring: tuple, hook: tuple, band: tuple,
                stim: tuple, hits: tuple, stop: tuple) -> None:  # fmt: skip
    """`platoon_step.after_one` of every env, `repeat` times (lead car, lanes, trace row, band
    control, stimuli, contacts, early stop), every env live."""
    for e in range(n):
        for k in range(repeat):
            live[e] = True
            after_one(e, k, live, a, lead, lanes, ring, hook, band, stim, hits, stop)


@borrowing_kernel
def _triggers_only(n: int, repeat: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, t: np.ndarray, trig: tuple) -> int:
    """`repeat` trigger searches and contact tests of every env (as `platoon_pass`)."""
    paused, shift, hx, hz, vols, vol_triggers, locks, near, _ = trig
    hits = 0
    for e in range(n):
        for _ in range(repeat):
            if not paused[e]:
                bx, bz = x[e] - shift * math.sin(yaw[e]), z[e] - shift * math.cos(yaw[e])
                j, near[e] = nearest_volume(bx, bz, vols, near[e])
                if j >= 0 and volume_fires(e, j, bx, bz, yaw[e], hx, hz, vols, vol_triggers, t[e], locks):
                    hits += 1
    return hits


def _cpu_ns(fn: Callable[[], object], restore: Callable[[], None], per: int, seconds: float) -> float:
    """CPU ns of fn() per `per` units, repeated for `seconds` of CPU, `restore()` (untimed) before each call."""
    k, spent = 0, 0.0
    while spent < seconds:
        restore()
        c0 = time.process_time()
        fn()
        spent += time.process_time() - c0
        k += 1
    return 1e9 * spent / (k * per)


def task_parts(env_id: str, n: int, steps: int, metrics: bool) -> dict[str, float]:
    """CPU ns per env-step of the native brake or platoon batch's step by part (random actions
    with resets, after warm-up steps): the Python-level parts timed by wrappers around their
    calls, the compiled physics pass split by running its pieces alone on a copy of the batch's
    state (ego cars, traffic cars, `after_one`, trigger search; each as many physics steps as a
    policy step has; the pass's rest is its loop, the reaction timers and the envs it skips)."""
    from opends_gym.vector import actions, env, platoon
    from opends_gym.vector.timers import TimerBatch
    from opends_gym.vector.triggers import TriggerBatch

    threads = os.environ.get("NUMBA_NUM_THREADS")
    from native_profile import physics_only  # (it sets NUMBA_NUM_THREADS for its own runs when unset: put back)

    if threads is None:
        os.environ.pop("NUMBA_NUM_THREADS", None)
    spent: dict[str, float] = {}
    pass_label = "physics pass (platoon_substeps)"
    named = [(platoon, "platoon_substeps", pass_label), (platoon, "_substeps_range", pass_label),
             (platoon, "traffic_events", "traffic events (Python: leg ends)"), (TriggerBatch, "fire", "trigger firing (Python)"),
             (TimerBatch, "score_ended", "timers scored (Python)"), (platoon, "platoon_finish", "finishing pass (platoon_finish)"),
             (platoon, "_finish_range", "finishing pass (platoon_finish)"),
             (actions.BatchActions, "convert", "action checks and conversion"),
             (env, "_check_actions", "action checks and conversion"), (platoon.PlatoonBatch, "reset_rows", "resets (reset_rows)"),
             (platoon.PlatoonBatch, "episodes_metrics", "episode scoring (episodes_metrics)"),
             (env, "_metrics_arrays", "episode_metrics arrays")]  # fmt: skip
    saved = [(o, name, getattr(o, name)) for o, name, _ in named]
    captured: list[tuple[object, ...]] = []

    def wrap(owner: object, name: str, label: str) -> None:
        fn = getattr(owner, name)

        def timed(*a: object, **kw: object) -> object:
            if name in ("platoon_substeps", "_substeps_range") and not a[0 if name == "platoon_substeps" else 2]:
                captured[:] = [a]
            c0 = time.process_time()
            try:
                return fn(*a, **kw)
            finally:
                spent[label] = spent.get(label, 0.0) + time.process_time() - c0

        setattr(owner, name, timed)

    for owner, name, label in named:
        wrap(owner, name, label)
    try:
        vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=metrics)
        vec.reset(seed=0)
        vec.action_space.seed(0)
        acts = [vec.action_space.sample() for _ in range(16)]
        for i in range(20):
            vec.step(acts[i % 16])
        wait_compiled()
        ends = 0
        spent.clear()
        c0 = time.process_time()
        for i in range(steps):
            _, _, term, trunc, _ = vec.step(acts[i % 16])
            ends += int(np.count_nonzero(term | trunc))
        total = time.process_time() - c0
    finally:
        for owner, name, fn in saved:
            setattr(owner, name, fn)
    out = {"whole step": 1e9 * total / (steps * n)}
    out |= {label: 1e9 * v / (steps * n) for label, v in sorted(spent.items(), key=lambda kv: -kv[1])}
    out["the rest (Python: step glue, info dict)"] = out["whole step"] - sum(1e9 * v / (steps * n) for v in spent.values())
    out["episodes ended per 1,000 env-steps"] = 1000 * ends / (steps * n)
    # the compiled pass's pieces alone, on copies of the batch's state
    core = vec.unwrapped.shards[0].core  # type: ignore[attr-defined]
    a = captured[0]
    off = 0 if len(a) == 22 else 2
    dt, controls, ego_t, traffic_t, trig_t = a[off + 3], a[off + 8], a[off + 9], a[off + 10], a[off + 11]
    at, lead_t, lanes_t, hook_t, band_t, stim_t, hits_t, stop_t = (a[off + i] for i in (13, 14, 15, 17, 18, 19, 20, 21))
    repeat = core.repeat
    state = [x for x in (*ego_t, *traffic_t, *trig_t, *at, *lead_t, *lanes_t, *hook_t, *stim_t, *hits_t, *stop_t)
             if isinstance(x, np.ndarray) and x.size]  # fmt: skip
    uniq = list({id(x): x for x in state}.values())
    saved_state = [x.copy() for x in uniq]

    def restore() -> None:
        for x, v in zip(uniq, saved_state):
            np.copyto(x, v)

    s = core.s
    p = core.p
    steer, gas, brake = (np.ascontiguousarray(x, dtype=np.float64) for x in controls)
    g = PLATOON_TRACE_GROUP
    block = np.zeros((-(-repeat // g), n, g, len(core.trace_columns)))  # (grouped, as `PlatoonBatch`'s ring)
    ring_t = (block, 0, np.zeros(n, dtype=np.int64), core._pedals, True)
    ones = np.ones(n, dtype=bool)
    t = core.t.copy()
    pieces = {
        "  ego cars alone (vector.ego)": lambda: physics_only(p.car, dt, repeat, s.x, s.z, s.yaw, s.u, steer, gas, brake),
        "  traffic cars alone (motion.step_rows)": lambda: _traffic_only(n, repeat, dt, traffic_t, t),
        "  after_one alone (lead, lanes, trace, band, stimuli, contacts)": lambda: _after_only(n, repeat, ones, at, lead_t, lanes_t, ring_t,
                                                                                           hook_t, band_t, stim_t, hits_t, stop_t),
        "  trigger search alone": lambda: _triggers_only(n, repeat, s.x, s.z, s.yaw, t, trig_t),
    }  # fmt: skip
    for fn in pieces.values():
        restore()
        fn()
    wait_compiled()
    for label, fn in pieces.items():
        out[label] = _cpu_ns(fn, restore, n, 1.0)
    restore()
    vec.close()
    return out


def parts_table(n: int, steps: int) -> None:
    print(f"\n| part ({n} envs, {steps} policy steps, NUMBA_NUM_THREADS={numba.get_num_threads()}) | "
          + " | ".join(f"{t} {'with' if m else 'no'} metrics" for t in TASKS[1:] for m in (False, True)) + " |")  # fmt: skip
    print("|---|" + "---:|" * 4)
    cols = [task_parts(f"OpenDS/{t}-v0", n, steps, m) for t in TASKS[1:] for m in (False, True)]
    keys = list(dict.fromkeys(k for c in cols for k in c))
    for k in keys:
        print(f"| {k} | " + " | ".join(f"{c[k]:,.0f}" if k in c else "-" for c in cols) + " |")


def profile(env_id: str, n: int, steps: int) -> tuple[float, float, float]:
    """(episodes ended per env-step, the share of them that ended with a collision, share of
    step time in episode scoring) over `steps` steps."""
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    vec.action_space.seed(0)
    actions = [vec.action_space.sample() for _ in range(steps + 3)]
    for a in actions[:3]:
        vec.step(a)
    ends = collided = 0
    pr = cProfile.Profile()
    pr.enable()
    for a in actions[3:]:
        _, _, term, trunc, info = vec.step(a)
        ends += int(np.sum(term | trunc))
        collided += int(np.sum(term & (info["new_collisions"] > 0)))
    pr.disable()
    vec.close()
    stats = pstats.Stats(pr).stats  # type: ignore[attr-defined]
    total = sum(v[3] for k, v in stats.items() if k[2] == "step" and k[0].endswith("vector/env.py"))
    scoring = sum(v[3] for k, v in stats.items() if k[2] == "episodes_metrics")
    return ends / (n * steps), collided / ends if ends else float("nan"), scoring / total if total else float("nan")


def table(rates: dict[str, list[float]], cpu: dict[str, list[float]]) -> None:
    """The rounds' medians and ranges as a markdown table."""
    print("\n| task | env-steps/s: rounds | median | of the LCT's | CPU ns per env-step: median (range) |")
    print("|---|---|---:|---:|---:|")
    lct = statistics.median(rates["LaneChangeTest"])
    for task in TASKS:
        r, c = rates[task], cpu[task]
        print(f"| {task} | {', '.join(f'{x / 1e3:,.1f}k' for x in r)} | {statistics.median(r) / 1e3:,.1f}k | "
              f"{100 * statistics.median(r) / lct:.1f} % | {statistics.median(c):,.0f} ({min(c):,.0f}-{max(c):,.0f}) |")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--motorway", type=int, default=0, help="also MotorwayTask as a native batch of this many envs")
    ap.add_argument("--motorway-only", action="store_true")
    ap.add_argument("--parts", action="store_true", help="the brake and platoon batches' step by part (CPU ns per env-step)")
    ap.add_argument("--parts-steps", type=int, default=60)
    ap.add_argument("--motorway-parts", action="store_true", help="also a per-part CPU profile of the MotorwayTask batch")
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    warnings.simplefilter("ignore")  # (the corpus task's missing scene mesh, once per env)
    if args.motorway:
        motorway_table(args.motorway, args.seconds, max(1, args.rounds))
        print("\n| traffic kernel alone, one thread: worlds | CPU ns per car and physics step: own step | of it `advance_carrots` | "
              "`drive` | following the shared history |")  # fmt: skip
        print("|---:|---:|---:|---:|---:|")
        for w in (64, 256, args.motorway):
            total, adv, drv, follow = traffic_kernel_ns(w, 1.0)
            print(f"| {w} | {total:.0f} | {adv:.0f} | {drv:.0f} | {follow:.1f} |", flush=True)
        if args.motorway_parts:
            motorway_parts(args.motorway, 40)
    if args.motorway_only:
        return
    if args.parts:
        parts_table(args.envs, args.parts_steps)
        return
    cases = {c.label: c for c in tp.opends_cases()}
    rates: dict[str, list[float]] = {t: [] for t in TASKS}
    cpu: dict[str, list[float]] = {t: [] for t in TASKS}
    for k in range(args.rounds):
        cells = []
        for task in TASKS:
            row = tp.measure_native(cases[task], "fast", args.envs, args.seconds, memory=False)
            assert row is not None and not row.note, f"{task}: no native batch ({row.note if row else 'none'})"
            rates[task].append(row.steps_per_s)
            cpu[task].append(1e9 / row.steps_per_cpu_s)
            cells.append(f"{task} {row.steps_per_s:,.0f}/s ({100 * row.cpu_share:.0f} % CPU, {cpu[task][-1]:,.0f} CPU ns/env-step)")
        print(f"round {k + 1}: " + " | ".join(cells), flush=True)
    if args.rounds:
        table(rates, cpu)
    if args.profile:
        print("\n| task | episodes ended per env-step | of them with a collision | step time scoring ended episodes (cProfile) |")
        print("|---|---:|---:|---:|")
        for task in TASKS:
            ends, collided, share = profile(cases[task].env_id, args.envs, 20)
            print(f"| {task} | {100 * ends:.2f} % | {100 * collided:.0f} % | {100 * share:.0f} % |", flush=True)


if __name__ == "__main__":
    main()
