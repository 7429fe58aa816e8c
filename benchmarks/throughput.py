"""How many policy steps per second do the OpenDS envs run, next to highway-env, in one run?

One table: every registered env (plus the corpus MotorwayTask with its 41 traffic cars) on
both physics backends, as a single env, in gymnasium's SyncVectorEnv and AsyncVectorEnv, and
in the native batch (`opends_gym.vector`) where that exists; highway-env's `highway-fast-v0`
and `highway-v0` are measured in the same run as the peer. Columns: policy steps per second
(all envs together), simulated seconds per wall second, the real-time factor of each env,
and resident memory per env (RSS growth while building the envs in this process; for
AsyncVectorEnv the proportional set size, PSS, of each worker process, which splits pages
shared after fork fairly). Then the goals of issue 9, measured again in interleaved rounds
(the peer and ours back to back, the median round decides PASS/FAIL), and a scaling table
for 1, 2, 4, ..., 256 Lane Change Test envs.

Actions are random (`action_space.sample()`, drawn before timing) and episodes that end are
reset inside the timed loop, so resets count; one more native row drives the LCT with a
lane follower (random steering leaves the road within ~5 s, so that row shows the batch
when episodes last, as a trained policy's do). Rates are wall-clock; `cpu %` is this
process's CPU time over wall time (below ~90 % another program shared the cores; above 100 %
the native batch ran its shards on two cores; not shown for worker processes), and `steps /
CPU s` the rate per CPU second. The native LCT is measured with its shards in threads (the
default) and in worker processes (`processes=`), with random actions and with the lane keeper.

    python benchmarks/throughput.py [--quick] [--seconds S] [--rounds R] [--out benchmarks/results/throughput.md]
    python benchmarks/throughput.py --native [--seconds S]   # the native-batch table alone

The native-batch table: the LCT, brake and platoon batches (4,096 envs) with and without
episode metrics in one run, their rates and CPU shares, each task's share of the LCT's
rate (wall and per CPU second), how often episodes end and what scoring one costs.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import logging
import os
import platform
import time
import tracemalloc
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the OpenDS ids)

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("OPENDS_CORPUS", ROOT.parent / "shared" / "opends-tasks"))
MOTORWAY = str(CORPUS / "opends-cts" / "MotorwayTask")
RESULTS = ROOT / "benchmarks" / "results" / "throughput.md"
SCALING_SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
VECTOR_ENVS = 4  # envs per gymnasium vector in the main table
NATIVE_ENVS = 4096  # envs in one native batch in the main table


@dataclass(frozen=True)
class Case:
    label: str
    env_id: str
    kwargs: dict[str, Any]
    policy_hz: float  # simulated seconds per policy step = 1 / policy_hz


def opends_cases() -> list[Case]:
    from opends_gym.envs.registration import ENVS

    out = []
    for env_id in ENVS:
        name = env_id.split("/")[1].split("-")[0]
        out.append(Case(name + (" (bundled ReactionTest)" if name == "DrivingTask" else ""), env_id, {}, 10.0))
    out.append(Case("MotorwayTask (41 cars)", "OpenDS/DrivingTask-v0", {"task": MOTORWAY, "terminate_on_collision": False}, 10.0))
    return out


HIGHWAY = (Case("highway-fast-v0", "highway-fast-v0", {}, 1.0), Case("highway-v0", "highway-v0", {}, 1.0))


@dataclass
class Row:
    label: str
    backend: str
    mode: str
    envs: int
    steps_per_s: float  # policy steps of all envs together
    sim_s_per_s: float
    mb_per_env: float
    cpu_share: float  # process CPU / wall (in-process modes)
    note: str = ""

    @property
    def rtf_per_env(self) -> float:
        return self.sim_s_per_s / self.envs

    @property
    def steps_per_cpu_s(self) -> float:
        """Policy steps per CPU second of this process (NaN for AsyncVectorEnv's workers)."""
        return self.steps_per_s / self.cpu_share if self.cpu_share == self.cpu_share and self.cpu_share > 0 else float("nan")


# ---------------------------------------------------------------------- memory
def _status_mb(pid: int | str, field: str, source: str = "status") -> float:
    try:
        with open(f"/proc/{pid}/{source}") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def rss_mb() -> float:
    return _status_mb("self", "VmRSS")


def grown_mb(build: Callable[[], list[Any]]) -> tuple[float, list[Any]]:
    """Memory that `build()` adds: RSS growth, or the traced Python/numpy allocations when the
    allocator reused pages freed earlier (whichever is larger; C++ memory, such as a pybullet
    client's, only shows in RSS)."""
    gc.collect()
    tracemalloc.start()
    before_rss = rss_mb()
    base, _ = tracemalloc.get_traced_memory()
    built = build()
    traced = (tracemalloc.get_traced_memory()[0] - base) / 2**20
    tracemalloc.stop()
    return max(rss_mb() - before_rss, traced), built


def pss_mb(pid: int) -> float:
    return _status_mb(pid, "Pss", "smaps_rollup")


def available_mb() -> float:
    return _status_mb("", "MemAvailable", "meminfo") if os.path.exists("/proc/meminfo") else float("nan")


# ---------------------------------------------------------------------- timing
def settle_compiles(step: Callable[[], object], rounds: int = 20) -> None:
    """Step until no kernel is left compiling in the background: until then kernels run as
    Python (same results, far slower), and a kernel first called late (the episode scoring,
    when episodes first end) starts its compile then."""
    from opends_gym.jit import compile_status, wait_compiled

    for _ in range(rounds):
        before = compile_status().get("python_calls", 0)
        wait_compiled()
        step()
        if compile_status().get("python_calls", 0) == before:
            return


def timed_steps(step: Callable[[int], None], seconds: float, batch: int = 20) -> tuple[float, float]:
    """Call step(i) until `seconds` of wall time passed; (calls per second, cpu share)."""
    for i in range(3):  # warm-up
        step(i)
    settle_compiles(lambda: step(0))
    gc.collect()  # (garbage of the previous measurement is not this one's cost)
    n, t0, c0 = 0, time.perf_counter(), time.process_time()
    while True:
        for _ in range(batch):
            step(n)
            n += 1
        wall = time.perf_counter() - t0
        if wall >= seconds:
            return n / wall, (time.process_time() - c0) / wall


def make_env(case: Case, backend: str | None) -> gym.Env[Any, Any]:
    kwargs = dict(case.kwargs)
    if backend is not None:
        kwargs["physics"] = backend
    return gym.make(case.env_id, **kwargs)


def measure_single(case: Case, backend: str | None, seconds: float, memory: bool = True) -> Row:
    env = make_env(case, backend)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(1024)]

    def step(i: int) -> None:
        _, _, terminated, truncated, _ = env.step(actions[i % 1024])
        if terminated or truncated:
            env.reset()

    rate, cpu = timed_steps(step, seconds)
    if not memory:
        env.close()
        return Row(case.label, backend or "-", "single", 1, rate, rate / case.policy_hz, float("nan"), cpu)

    # memory: grow the process by a few more envs of the same kind (imports already paid)
    def build() -> list[Any]:
        envs = [make_env(case, backend) for _ in range(2)]
        for k, e in enumerate(envs):
            e.reset(seed=k)
        return envs

    grown, extra = grown_mb(build)
    mb = grown / len(extra)
    for e in [env, *extra]:
        e.close()
    return Row(case.label, backend or "-", "single", 1, rate, rate / case.policy_hz, mb, cpu)


def measure_vector(case: Case, backend: str | None, mode: str, n: int, seconds: float) -> Row:
    fns = [lambda: make_env(case, backend) for _ in range(n)]

    def build() -> list[Any]:
        v = gym.vector.SyncVectorEnv(fns) if mode == "sync" else gym.vector.AsyncVectorEnv(fns)
        v.reset(seed=0)
        return [v]

    if mode == "sync":
        grown, (vec,) = grown_mb(build)
        mb = grown / n
    else:  # (no tracemalloc here: forked workers would inherit it)
        (vec,) = build()
        mb = float(np.mean([pss_mb(p.pid) for p in vec.processes]))
    try:
        vec.action_space.seed(0)
        actions = [vec.action_space.sample() for _ in range(64)]
        rate, cpu = timed_steps(lambda i: vec.step(actions[i % 64]), seconds, batch=max(1, 64 // n))
    finally:
        vec.close()
    steps = rate * n
    return Row(case.label, backend or "-", mode, n, steps, steps / case.policy_hz, mb, cpu if mode == "sync" else float("nan"))


def native_batch_available(env_id: str = "OpenDS/LaneChangeTest-v0") -> bool:
    """Whether `gymnasium.make_vec(env_id, vectorization_mode="vector_entry_point")` has a
    native batch (issue 9 item 2, `opends_gym.vector`) for this id."""
    if importlib.util.find_spec("opends_gym.vector") is None:
        return False
    spec = gym.registry.get(env_id)
    return spec is not None and getattr(spec, "vector_entry_point", None) is not None


def lane_keeping(obs: np.ndarray) -> np.ndarray:
    """The LCT's instructed-lane follower of `benchmarks/native_batch.py` (episodes run to the
    end of the track, as a trained policy's do; random actions leave the road in ~5 s)."""
    a = np.zeros((len(obs), 2), dtype=np.float32)
    a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
    return a


def measure_native(case: Case, backend: str, n: int, seconds: float, keep_lane: bool = False, processes: int | None = None,
                   memory: bool = True, metrics: bool = True) -> Row | None:  # fmt: skip
    """The natively batched env of `opends_gym.vector`, where one exists for this id and backend
    (random actions, or with `keep_lane` the LCT lane follower; shards in threads, or with
    `processes` in that many worker processes)."""
    if case.kwargs or not native_batch_available(case.env_id):
        return None
    shards: dict[str, Any] = {"processes": processes} if processes else {}
    if not metrics:
        shards["record_metrics"] = False

    def build() -> list[Any]:
        v = gym.make_vec(case.env_id, num_envs=n, vectorization_mode="vector_entry_point", physics=backend, **shards)
        v.reset(seed=0)
        return [v]

    try:
        grown, (vec,) = grown_mb(build) if memory else (float("nan"), build())
    except Exception as e:  # e.g. a backend the batch does not support
        return Row(case.label, backend, "native", n, 0, 0, 0, 0, note=f"n/a ({type(e).__name__}: {str(e)[:60]})")
    try:
        mb = grown / n
        if keep_lane:
            last = [vec.reset(seed=0)[0]]

            def step(i: int) -> None:
                last[0] = vec.step(lane_keeping(last[0]))[0]

            rate, cpu = timed_steps(step, seconds, batch=4)
        else:
            vec.action_space.seed(0)
            actions = [vec.action_space.sample() for _ in range(16)]
            rate, cpu = timed_steps(lambda i: vec.step(actions[i % 16]), seconds, batch=4)
    finally:
        vec.close()
    label = f"{case.label} (lane keeping)" if keep_lane else case.label
    mode = f"native, {processes} processes" if processes else "native"
    mode += "" if metrics else ", no metrics"
    if processes:
        cpu = float("nan")  # the workers' CPU time is not this process's
    return Row(label, backend, mode, n, rate * n, rate * n / case.policy_hz, mb, cpu)


NATIVE_TASKS = ("LaneChangeTest", "BrakeReaction", "ThreeVehiclePlatoon")


@dataclass
class NativeRow:
    task: str
    metrics: bool
    steps_per_s: float  # env-steps of the whole batch per wall second
    cpu_share: float  # this process's CPU time over wall time
    ends_per_k: float  # episodes ended per 1,000 env-steps
    scoring_us: float  # CPU microseconds per ended episode in the core's `episodes_table` (else `episodes_metrics`)

    @property
    def steps_per_cpu_s(self) -> float:
        return self.steps_per_s / self.cpu_share if self.cpu_share > 0 else float("nan")


def measure_native_task(case: Case, n: int, seconds: float, metrics: bool) -> NativeRow:
    """One native batch of `n` envs with random actions and resets, with or without metrics:
    its rate, CPU share, how often episodes end and what scoring one costs (the CPU time inside
    each shard's `episodes_table` or `episodes_metrics`: of the calling thread, or of the
    process for a core scoring on numba's threads; other programs on the host do not count)."""
    vec: Any = gym.make_vec(case.env_id, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=metrics)
    scoring = [0.0, 0]
    for shard in vec.unwrapped.shards:
        core = getattr(shard, "core", None)
        if core is None:
            continue

        # the table where the core hands one over (`shards.ended_metrics`); a core that scores on numba's threads
        # (`parallel`: then the batch's only shard, and the calling thread waits) is timed by the process's CPU time
        name = "episodes_table" if hasattr(core, "episodes_table") else "episodes_metrics"
        clock = time.process_time if getattr(core, "parallel", False) else time.thread_time
        score = getattr(core, name)

        def timed(es: list[int], _score: Callable[[list[int]], Any] = score, _clock: Any = clock) -> Any:
            t = _clock()
            out = _score(es)
            scoring[0] += _clock() - t
            scoring[1] += len(es)
            return out

        setattr(core, name, timed)
    try:
        vec.reset(seed=0)
        vec.action_space.seed(0)
        actions = [vec.action_space.sample() for _ in range(16)]
        ends = [0, 0]

        def step(i: int) -> None:
            _, _, term, trunc, _ = vec.step(actions[i % 16])
            ends[0] += int(np.count_nonzero(term | trunc))
            ends[1] += n

        for i in range(3):  # warm-up, then count from zero
            step(i)
        settle_compiles(lambda: step(0))
        ends[:], scoring[:] = [0, 0], [0.0, 0]
        rate, cpu = timed_steps(step, seconds, batch=4)
    finally:
        vec.close()
    per_end = 1e6 * scoring[0] / scoring[1] if scoring[1] else float("nan")
    return NativeRow(case.label, metrics, rate * n, cpu, 1000.0 * ends[0] / max(ends[1], 1), per_end)


def native_tasks_table(seconds: float, n: int) -> list[str]:
    """The native LCT, brake and platoon batches with and without episode metrics, measured
    back to back in this run, and each as a share of the LCT's rate (wall and per CPU second:
    on a shared host the CPU-time figures compare better)."""
    cases = {c.label: c for c in opends_cases()}
    rows = [measure_native_task(cases[t], n, seconds, m) for m in (True, False) for t in NATIVE_TASKS]
    lct = {r.metrics: r for r in rows if r.task == "LaneChangeTest"}
    out = [
        f"| task ({n:,} envs, random actions, resets) | metrics | env-steps/s | cpu % | env-steps / CPU s | of the LCT's (wall) "
        "| of the LCT's (per CPU s) | episodes ended / 1k env-steps | scoring: CPU µs / ended episode |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        base = lct[r.metrics]
        out.append(
            f"| {r.task} | {'on' if r.metrics else 'off'} | {fmt(r.steps_per_s)} | {fmt(100 * r.cpu_share)} | {fmt(r.steps_per_cpu_s)} "
            f"| {fmt(100 * r.steps_per_s / base.steps_per_s, 1)} % | {fmt(100 * r.steps_per_cpu_s / base.steps_per_cpu_s, 1)} % "
            f"| {fmt(r.ends_per_k, 2)} | {fmt(r.scoring_us) if r.metrics else '-'} |"
        )
    return out


# ---------------------------------------------------------------------- report
def fmt(x: float, digits: int = 0) -> str:
    if x != x:
        return "-"
    return f"{x:,.{digits}f}"


def table(rows: list[Row]) -> list[str]:
    out = [
        "| env | backend | mode | envs | policy steps/s | sim s / wall s | real-time factor per env | MB RSS / env | cpu % "
        "| steps / CPU s |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if r.note:
            out.append(f"| {r.label} | {r.backend} | {r.mode} | {r.envs} | {r.note} | | | | | |")
            continue
        rtf = fmt(r.rtf_per_env, 1)
        out.append(
            f"| {r.label} | {r.backend} | {r.mode} | {r.envs} | {fmt(r.steps_per_s)} | {fmt(r.sim_s_per_s, 1)} | {rtf} "
            f"| {fmt(r.mb_per_env, 1)} | {fmt(100 * r.cpu_share)} | {fmt(r.steps_per_cpu_s)} |"
        )
    return out


def find(rows: list[Row], label: str, backend: str, mode: str) -> Row | None:
    return next((r for r in rows if r.label.startswith(label) and r.backend == backend and r.mode == mode and not r.note), None)


@dataclass
class Round:
    """One round of the goal measurements, taken back to back so the peer and our envs see the
    same host (a shared machine's speed drifts by tens of percent over minutes)."""

    peer_steps: float  # highway-fast-v0 policy steps/s (= simulated s per wall s: 1 Hz policy)
    lct_steps: float
    motorway_sim: float
    native_random: float
    native_keep: float
    native_bare: float  # random actions, record_metrics=False
    brake_random: float
    platoon_random: float

    @property
    def lct_ratio(self) -> float:
        return self.lct_steps / self.peer_steps

    @property
    def motorway_ratio(self) -> float:
        return self.motorway_sim / self.peer_steps


def goal_rounds(rounds: int, seconds: float, native_envs: int) -> list[Round]:
    """The goal measurements `rounds` times over, interleaved."""
    peer = HIGHWAY[0]
    cases = {c.label: c for c in opends_cases()}
    lct, motorway = cases["LaneChangeTest"], cases["MotorwayTask (41 cars)"]
    out = []
    for k in range(rounds):
        hw = measure_single(peer, None, seconds, memory=False)
        one = measure_single(lct, "fast", seconds, memory=False)
        mw = measure_single(motorway, "fast", seconds, memory=False)
        rand = measure_native(lct, "fast", native_envs, seconds, memory=False)
        keep = measure_native(lct, "fast", native_envs, seconds, keep_lane=True, memory=False)
        bare = measure_native(lct, "fast", native_envs, seconds, memory=False, metrics=False)
        brake = measure_native(cases["BrakeReaction"], "fast", native_envs, seconds, memory=False)
        platoon = measure_native(cases["ThreeVehiclePlatoon"], "fast", native_envs, seconds, memory=False)

        def rate(row: Row | None) -> float:
            return row.steps_per_s if row is not None and not row.note else float("nan")

        out.append(Round(hw.steps_per_s, one.steps_per_s, mw.sim_s_per_s, rate(rand), rate(keep), rate(bare), rate(brake), rate(platoon)))
        r = out[-1]
        print(f"round {k + 1}: peer {r.peer_steps:.1f}, LCT {r.lct_ratio:.0f}x, Motorway {r.motorway_ratio:.1f}x, native LCT "
              f"{r.native_random:,.0f} / {r.native_bare:,.0f} / {r.native_keep:,.0f} (random / random, no metrics / lane keeping), "
              f"brake {r.brake_random:,.0f}, platoon {r.platoon_random:,.0f}", flush=True)  # fmt: skip
    return out


def goals(rows: list[Row], rounds: list[Round]) -> list[str]:
    """PASS/FAIL per goal from the median of the rounds (each ratio from measurements taken
    back to back); the bullet goals from the main table. Then every round's figures."""
    out = ["| goal | median of rounds | target | result |", "|---|---:|---:|---|"]

    def line(goal: str, values: list[float], target: float, unit: str) -> None:
        values = [v for v in values if v == v]
        if not values:
            out.append(f"| {goal} | n/a | {target:,.0f}{unit} | n/a (not built) |")
            return
        value = float(np.median(values))
        out.append(f"| {goal} | {fmt(value, 1)}{unit} | {target:,.0f}{unit} | {'PASS' if value >= target else 'FAIL'} |")

    line("single LCT (fast) policy steps/s vs highway-fast-v0 (random actions, resets)", [r.lct_ratio for r in rounds], 300, "x")
    line("MotorwayTask (fast, 41 cars) simulated s per wall s vs highway-fast-v0", [r.motorway_ratio for r in rounds], 10, "x")
    line("native LCT env-steps/s, random actions, without metrics", [r.native_bare for r in rounds], 5_000_000, "")
    line("native LCT env-steps/s, random actions, with metrics", [r.native_random for r in rounds], 3_000_000, "")
    line("native LCT env-steps/s, lane keeping, with metrics (episodes last)", [r.native_keep for r in rounds], 1_000_000, "")
    line("native brake test / native LCT, random actions, with metrics", [100 * r.brake_random / r.native_random for r in rounds], 80, " %")
    line(
        "native platoon test / native LCT, random actions, with metrics",
        [100 * r.platoon_random / r.native_random for r in rounds],
        80,
        " %",
    )
    out.append("| native MotorwayTask (41 cars, triggers) env-steps/s | n/a (not built) | 100,000 | n/a (not built) |")
    for label in ("LaneChangeTest", "MotorwayTask"):
        b = find(rows, label, "bullet", "single")
        line(f"bullet backend real-time factor ({label}, main table)", [b.rtf_per_env] if b else [], 50, "x")
    out += ["", "| round | highway-fast-v0 steps/s | LCT steps/s | LCT ratio | Motorway sim s/s | Motorway ratio | native LCT random "
            "| native LCT random, no metrics | native LCT lane keeping | native brake random | native platoon random |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for k, r in enumerate(rounds):
        out.append(f"| {k + 1} | {fmt(r.peer_steps, 1)} | {fmt(r.lct_steps)} | {fmt(r.lct_ratio)}x | {fmt(r.motorway_sim)} | "
                   f"{fmt(r.motorway_ratio, 1)}x | {fmt(r.native_random)} | {fmt(r.native_bare)} | {fmt(r.native_keep)} | "
                   f"{fmt(r.brake_random)} | {fmt(r.platoon_random)} |")  # fmt: skip
    return out


def scaling(seconds: float, sizes: tuple[int, ...], async_max: int) -> list[str]:
    lct = Case("LaneChangeTest", "OpenDS/LaneChangeTest-v0", {}, 10.0)
    out = [
        "| envs | sync steps/s | sync MB/env | async steps/s | async MB (PSS)/env | native steps/s |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    async_note = ""
    per_worker_mb = 150.0  # until measured: a worker process with its own interpreter and env
    for n in sizes:
        s = measure_vector(lct, "fast", "sync", n, seconds)
        cells = [str(n), fmt(s.steps_per_s), fmt(s.mb_per_env, 1)]
        if async_note:
            cells += [async_note, ""]
        elif n > async_max:
            async_note = f"skipped from {n}: beyond --async-max {async_max} (time budget)"
            cells += [async_note, ""]
        else:
            need = n * per_worker_mb * 1.5
            if need > 0.5 * available_mb():
                async_note = f"skipped from {n}: ~{need / 1024:.1f} GB of workers > half the free memory"
                cells += [async_note, ""]
            else:
                a = measure_vector(lct, "fast", "async", n, seconds)
                cells += [fmt(a.steps_per_s), fmt(a.mb_per_env, 1)]
                per_worker_mb = a.mb_per_env if a.mb_per_env == a.mb_per_env else per_worker_mb
        nat = measure_native(lct, "fast", n, seconds)
        cells.append((nat.note or fmt(nat.steps_per_s)) if nat else "n/a (not built)")
        out.append("| " + " | ".join(cells) + " |")
        print(out[-1], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer rows and shorter runs (about 2 minutes)")
    ap.add_argument("--seconds", type=float, default=None, help="wall seconds per measurement")
    ap.add_argument("--async-max", type=int, default=None, help="largest AsyncVectorEnv in the scaling table")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds of the goal measurements")
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--native", action="store_true", help="only the native LCT/brake/platoon table, with and without metrics (~1 min)")
    args = ap.parse_args()
    logging.disable(logging.WARNING)  # corpus tasks warn about their quirks at load time
    warnings.filterwarnings("ignore")
    quick = args.quick
    seconds = args.seconds or (0.6 if quick else 2.0)
    if args.native:
        native = native_tasks_table(args.seconds or 3.0, NATIVE_ENVS)
        print("\n".join(["", f"`python benchmarks/throughput.py --native` on {os.cpu_count()} cores, {time.strftime('%Y-%m-%d %H:%M')}",
                         "", *native]))  # fmt: skip
        return
    async_max = args.async_max or (4 if quick else 64)
    sizes = (1, 4, 16, 64) if quick else SCALING_SIZES
    native_envs = 1024 if quick else NATIVE_ENVS
    from opends_gym.errors import UserError
    from opends_gym.extras import require

    try:
        require("bench", "highway_env", "the highway-env comparison")  # importing it registers the highway ids
        require("bullet", "pybullet", "the bullet rows")
    except UserError as e:
        raise SystemExit(f"throughput.py: {e}") from None
    t_start = time.perf_counter()
    rows: list[Row] = []

    for case in HIGHWAY:
        rows.append(measure_single(case, None, seconds * (1.5 if quick else 3.0)))
        print(table(rows[-1:])[-1], flush=True)
    for case in opends_cases():
        is_main = case.label.startswith(("LaneChangeTest", "MotorwayTask"))
        for backend in ("fast", "bullet"):
            if quick and backend == "bullet" and not is_main:
                continue
            rows.append(measure_single(case, backend, seconds))
            print(table(rows[-1:])[-1], flush=True)
            if quick and not is_main:
                continue
            for mode in ("sync", "async"):
                rows.append(measure_vector(case, backend, mode, VECTOR_ENVS, seconds))
                print(table(rows[-1:])[-1], flush=True)
    # native batches last: thousands of envs in one process leave a large heap behind them
    missing = "n/a (not built)" if importlib.util.find_spec("opends_gym.vector") is None else "n/a (no native batch for this env)"
    for case in opends_cases():
        for backend in ("fast", "bullet"):
            if quick and backend == "bullet":
                continue
            nat = measure_native(case, backend, native_envs, seconds)
            rows.append(nat or Row(case.label, backend, "native", native_envs, 0, 0, 0, 0, note=missing))
            print(table(rows[-1:])[-1], flush=True)
    lct = next(c for c in opends_cases() if c.label == "LaneChangeTest")
    workers = min(4, os.cpu_count() or 1)
    for keep_lane, processes in ((False, workers), (True, None), (True, workers)):
        if processes is not None and processes < 2:
            continue
        extra = measure_native(lct, "fast", native_envs, seconds, keep_lane=keep_lane, processes=processes)
        if extra is not None:
            rows.append(extra)
            print(table(rows[-1:])[-1], flush=True)
    order = [c.label for c in (*HIGHWAY, *opends_cases())]
    rows.sort(key=lambda r: order.index(r.label.removesuffix(" (lane keeping)")))  # (a stable sort: the modes keep their order)
    main_table = table(rows)
    rounds = goal_rounds(args.rounds, seconds, native_envs)
    goal_table = goals(rows, rounds)
    print("\n".join(["", *goal_table, ""]), flush=True)
    native_table = native_tasks_table(seconds, native_envs)
    print("\n".join(["", *native_table, ""]), flush=True)
    scale_table = scaling(seconds, sizes, async_max)
    elapsed = time.perf_counter() - t_start
    header = [
        "# Throughput (issue 9)",
        "",
        f"`python benchmarks/throughput.py{' --quick' if quick else ''}` on {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}, {time.strftime('%Y-%m-%d %H:%M')}; "
        f"{seconds:.1f} s per measurement, {elapsed / 60:.1f} min in all.",
        "Random actions with resets; vector rows use "
        f"{VECTOR_ENVS} envs (native: {native_envs}); MB/env is RSS growth in this process (async: worker PSS).",
        "",
    ]
    scale_intro = ["", "## Scaling: LaneChangeTest-v0 (fast backend), env-steps per second", ""]
    goal_intro = [
        "## Goals",
        "",
        f"Measured again in {len(rounds)} rounds after the main table; in each round highway-fast-v0, the single LCT, the "
        f"MotorwayTask and the native LCT batch ({native_envs} envs, random actions and lane keeping) run back to back for "
        f"{seconds:.1f} s each, so every ratio compares measurements taken on the same host moments apart. A goal passes when "
        "the median of its rounds meets it.",
        "",
    ]
    native_intro = [
        "",
        f"## Native batches: LCT, brake and platoon tests, {native_envs:,} envs, with and without episode metrics",
        "",
        "Measured back to back in this run. `cpu %` is this process's CPU time over wall time (the host is shared: below "
        "the core count, other programs took the rest), `env-steps / CPU s` the rate per CPU second, and the shares of the "
        "LCT's rate compare each task with the LCT's row of the same metrics setting. Scoring: CPU time per ended episode "
        "in the core's `episodes_table` (else `episodes_metrics`): of the scoring thread, or of the process where the "
        "core scores on numba's threads (the LCT's).",
        "",
    ]
    text = "\n".join([*header, *main_table, "", *goal_intro, *goal_table, *native_intro, *native_table, *scale_intro, *scale_table, ""])
    print("\n" + text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(f"written to {args.out}")


if __name__ == "__main__":
    main()
