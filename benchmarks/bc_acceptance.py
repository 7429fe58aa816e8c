"""Behaviour-cloning acceptance (issue 22): how close a clone drives to the drives it was cloned from.

1. LCT: --drives episodes of virtual participant --participant (baseline load) on the Lane Change
   Test become a Minari dataset; a clone is trained on it; over --eval new seeds the clone's and the
   participant's mean MDEV (mdev_basic_m), SDLP (sdlp_m) and lane-change latency
   (mean_lane_change_latency_s) are compared (goal: within 15 %).
2. Countryside: the real OpenDS drives in tests/data/opends-drives are exported through the task's
   env (from each log's first gas: --trim-idle), a clone is trained on them and
   drives the task for 60 s; the figure is the largest distance from the clone's path to the
   nearest point of the paths those logs recorded (goal: 5 m), and how far the clone drove
   (`driven_m`: a clone that stays at the start is trivially on the path).

    PYTHONPATH=. python benchmarks/bc_acceptance.py --drives 200 --eval 20 --history 15   # the full acceptance
    PYTHONPATH=. python benchmarks/bc_acceptance.py --drives 10 --eval 5        # a quick look
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DRIVES = ROOT / "tests" / "data" / "opends-drives"
METRICS = ("mdev_basic_m", "sdlp_m", "mean_lane_change_latency_s")


def lct(participant: int, drives: int, evaluate: int, epochs: int, tmp: Path, history: int = 1) -> dict[str, object]:
    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent

    spec = f"participant:{participant}"
    env = make_env("OpenDS/LaneChangeTest-v0", {})
    agent = make_agent(spec)
    episodes = [collect(env, agent, seed) for seed in range(drives)]
    write_dataset("bench/lct-participant", episodes)
    summary = train_bc("bench/lct-participant-v0", tmp / "lct-clone", BCConfig(epochs=epochs, history=history))
    clone = make_agent(f"bc:{tmp / 'lct-clone'}")
    seeds = range(10_000, 10_000 + evaluate)
    person = [collect(env, agent, s).metrics for s in seeds]
    cloned = [collect(env, clone, s).metrics for s in seeds]
    env.close()
    out: dict[str, object] = {
        "participant": spec,
        "history": history,
        "drives": drives,
        "eval_episodes": evaluate,
        "train_mse": summary["final_mse"],
    }
    for m in METRICS:
        a = float(np.nanmean([e.get(m, np.nan) for e in person]))
        b = float(np.nanmean([e.get(m, np.nan) for e in cloned]))
        out[m] = {"participant": a, "clone": b, "relative_difference": abs(b - a) / abs(a) if a else float("nan")}
    out["clone_signs_reached"] = float(np.mean([e.get("signs_reached", np.nan) for e in cloned]))
    return out


def countryside(epochs: int, seconds: float, tmp: Path) -> dict[str, object]:
    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.episodes import collect, load_episode, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent
    from opends_gym.record.cardata import read_cardata

    task = str(DRIVES / "Countryside")
    logs = sorted((DRIVES / "drives").glob("*/carData*.txt"))
    episodes = [load_episode(p, None, task, trim_idle=True) for p in logs]
    write_dataset("bench/countryside", episodes)
    train_bc("bench/countryside-v0", tmp / "cs-clone", BCConfig(epochs=epochs))
    path = np.concatenate([np.c_[c.columns["x_m"], c.columns["z_m"]] for c in map(read_cardata, logs)])
    env = make_env("OpenDS/DrivingTask-v0", {"task": str(Path(task).resolve()), "action": "continuous", "max_episode_s": seconds})
    clone = make_agent(f"bc:{tmp / 'cs-clone'}")
    collect(env, clone, 0)
    trace = env.unwrapped.trace
    xz = np.c_[trace.col("x_m"), trace.col("z_m")]
    t_end = float(env.unwrapped.world.t_s)
    env.close()
    dist = np.sqrt(((xz[:, None, :] - path[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
    return {
        "logs": len(logs),
        "steps": sum(e.steps for e in episodes),
        "driven_s": t_end,
        "driven_m": float(np.hypot(*np.diff(xz, axis=0).T).sum()),  # a clone that stands still is trivially on the path
        "max_distance_m": float(dist.max()),
        "mean_distance_m": float(dist.mean()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--participant", type=int, default=1)
    ap.add_argument("--drives", type=int, default=200)
    ap.add_argument("--eval", type=int, default=20)
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--history", type=int, default=1, help="observations the LCT clone sees (drivers.bc)")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--skip-lct", action="store_true")
    ap.add_argument("--skip-countryside", action="store_true")
    args = ap.parse_args()
    import os

    with tempfile.TemporaryDirectory() as d:
        os.environ["MINARI_DATASETS_PATH"] = str(Path(d) / "minari")
        start = time.perf_counter()
        result: dict[str, object] = {}
        if not args.skip_countryside:
            result["countryside"] = countryside(args.epochs, args.seconds, Path(d))
        if not args.skip_lct:
            result["lct"] = lct(args.participant, args.drives, args.eval, args.epochs, Path(d), args.history)
        result["wall_s"] = time.perf_counter() - start
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
