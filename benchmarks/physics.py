"""How fast do the physics backends simulate a driving task?

For each backend (`fast`, `bullet`) and task (the bundled LaneChangeTest, the corpus
ReactionTest with its 3 MB scene, and the corpus MotorwayTask with its traffic), the script
builds a `World`, drives it for N simulated seconds at 60 Hz with half throttle, and prints
one table: World build time, steps per second and the real-time factor, and the goal beside
it (fast >= 500x, bullet >= 50x real time). Rates are given per CPU second of this process
(what a dedicated core would do; the goal is checked on it) and per wall-clock second (what
this run got on a possibly shared machine). Clocks are read here only, never inside the
simulation. The best of `--repeat` runs is reported.

    python benchmarks/physics.py [--seconds 60] [--repeat 3]
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("OPENDS_CORPUS", ROOT.parent / "shared" / "opends-tasks"))
GOALS = {"fast": 500.0, "bullet": 50.0}  # real-time factor at 60 Hz
DT_S = 1.0 / 60.0


@dataclass(frozen=True)
class Case:
    label: str
    source: str  # bundled task name or corpus folder
    traffic: bool


CASES = (
    Case("LaneChangeTest (bundled)", "LaneChangeTest", False),
    Case("ReactionTest (corpus, 3 MB scene)", "opends-cts/ReactionTest", False),
    Case("MotorwayTask (corpus, traffic)", "opends-cts/MotorwayTask", True),
)


@dataclass(frozen=True)
class Row:
    task: str
    backend: str
    load_s: float
    build_s: float
    steps_per_s: float  # per CPU second
    wall_steps_per_s: float
    physics_share: float  # steps with physics on (not paused by the task)
    traffic: int

    @property
    def realtime(self) -> float:
        return self.steps_per_s * DT_S


def traffic_available() -> bool:
    return importlib.util.find_spec("opends_gym.sim.traffic.manager") is not None


def load(case: Case) -> tuple[DrivingTask, float]:
    path: str | Path = case.source if "/" not in case.source else CORPUS / case.source
    t0 = time.perf_counter()
    task = load_task(path)
    return task, time.perf_counter() - t0


def measure(case: Case, task: DrivingTask, load_s: float, backend: str, seconds: float, repeat: int) -> Row:
    config = WorldConfig(physics=backend, dt_s=DT_S, traffic=case.traffic)
    controls = DriverControls(accelerator=0.5)
    steps = int(round(seconds / DT_S))
    best_build = best_rate = best_wall = 0.0
    share = 0.0
    vehicles = 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        world = World(task, config)
        build = time.perf_counter() - t0
        physics_steps = 0
        t1, c1 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            world.step(controls)
            physics_steps += not world.paused
        wall, cpu = time.perf_counter() - t1, time.process_time() - c1
        vehicles = len(getattr(world.traffic, "objects", ())) if world.traffic is not None else 0
        world.close()
        best_build = build if best_build == 0.0 else min(best_build, build)
        best_rate = max(best_rate, steps / max(cpu, 1e-9))
        best_wall = max(best_wall, steps / wall)
        share = physics_steps / steps
    return Row(case.label, backend, load_s, best_build, best_rate, best_wall, share, vehicles)


def print_table(rows: list[Row], notes: list[str], seconds: float, repeat: int) -> None:
    print(f"physics backends: {seconds:g} simulated s at 60 Hz, best of {repeat}, half throttle")
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the end\n")
    head = (
        f"{'task':<34} {'backend':<7} {'load s':>6} {'build s':>7} {'steps/cpu s':>11} {'x real time':>11} {'goal':>6} {'met':>4}"
        f" {'steps/wall s':>12} {'x (wall)':>8} {'physics':>7} {'traffic':>7}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        goal = GOALS[r.backend]
        met = "yes" if r.realtime >= goal else "NO"
        print(
            f"{r.task:<34} {r.backend:<7} {r.load_s:>6.2f} {r.build_s:>7.3f} {r.steps_per_s:>11.0f} {r.realtime:>10.0f}x"
            f" {goal:>5.0f}x {met:>4} {r.wall_steps_per_s:>12.0f} {r.wall_steps_per_s * DT_S:>7.0f}x {r.physics_share:>7.0%} {r.traffic:>7}"
        )
    for note in notes:
        print(note)
    print(
        "\nload s: reading the task's XML (once per task); build s: World construction (wall clock);"
        " physics: share of steps not paused by the task; traffic: traffic objects simulated."
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run (default 60)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per cell; the best is reported (default 3)")
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.repeat < 1:
        parser.error("--seconds must be positive and --repeat at least 1")
    logging.disable(logging.WARNING)  # missing 3D assets are expected: the corpus ships XML only
    rows: list[Row] = []
    notes: list[str] = []
    for case in CASES:
        if case.traffic and not traffic_available():
            notes.append(f"{case.label}: traffic not available (opends_gym.sim.traffic.manager is missing); not measured")
            continue
        if "/" in case.source and not (CORPUS / case.source).is_dir():
            notes.append(f"{case.label}: corpus not found at {CORPUS} (set OPENDS_CORPUS); not measured")
            continue
        task, load_s = load(case)
        for backend in ("fast", "bullet"):
            rows.append(measure(case, task, load_s, backend, args.seconds, args.repeat))
    print_table(rows, notes, args.seconds, args.repeat)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
