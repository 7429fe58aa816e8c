"""Behaviour-cloning acceptance (issue 22): how close a clone drives to the drives it was cloned from.

1. LCT: --drives episodes of virtual participant --participant (baseline load) on the Lane Change
   Test become a Minari dataset; a clone is trained on it; over --eval new seeds (10000 on, never
   trained on) the clone's and the participant's mean MDEV (mdev_basic_m), SDLP (sdlp_m) and
   lane-change latency (mean_lane_change_latency_s) are compared (goal: each within 15 %).
2. Countryside: the real OpenDS drives in tests/data/opends-drives are exported through the task's
   env (each from its own first state at its first gas: --trim-idle; on_collision continue), a clone is trained on them and drives the task
   for 60 s; the figure is the largest distance from the clone's path to the nearest point of the
   paths those logs recorded (goal: 5 m) over 60 s driven; a clone that leaves the road early
   fails, and so does one that drives less far than the longest log did (one that stands still
   is trivially on the path). The rule driver's row is a reference: where the road itself leads
   away from the logs' paths (they cover parts of it only), no driver that follows it stays within 5 m.

Drives are collected in a process pool (--workers) and cached under --cache (the Minari datasets
and the participant's evaluation metrics), so a second run only trains and evaluates the clones.
The cache sits in a folder named by `source_key()`: a hash of the package's version, this script and
every source file of opends_gym (env, participant model, export) and of the bundled drives, so a change to
any of them collects the drives anew instead of reusing stale ones.
Prints one table (goal, measured, pass) and, with --json, the full figures.

    PYTHONPATH=. python benchmarks/bc_acceptance.py                      # the acceptance (200 drives, 20 episodes)
    PYTHONPATH=. python benchmarks/bc_acceptance.py --drives 20 --eval 4 # a quick look
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import multiprocessing
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DRIVES = ROOT / "tests" / "data" / "opends-drives"
LCT = "OpenDS/LaneChangeTest-v0"
METRICS = ("mdev_basic_m", "sdlp_m", "mean_lane_change_latency_s")
EVAL_SEED = 10_000  # evaluation seeds start here; training drives use 0..drives-1


def source_key() -> str:
    """12 hex digits that change with the package version, any opends_gym source file or the bundled
    drives: what the cached drives were made with (the participant model, the envs, the export)."""
    from importlib.metadata import version

    h = hashlib.sha256(version("opends-gym").encode())
    files = [Path(__file__).resolve(), *sorted((ROOT / "opends_gym").rglob("*.py")), *sorted(p for p in DRIVES.rglob("*") if p.is_file())]
    for p in files:
        h.update(p.relative_to(ROOT).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:12]


def _episodes(spec: str, seeds: list[int]) -> list[Any]:
    """Episodes of agent `spec` on the LCT, one per seed (a pool worker's share)."""
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.drivers.agents import make_agent

    env = make_env(LCT, {})
    agent = make_agent(spec)
    try:
        return [collect(env, agent, s) for s in seeds]
    finally:
        env.close()


def _metrics(spec: str, seeds: list[int]) -> list[dict[str, float]]:
    return [ep.metrics for ep in _episodes(spec, seeds)]


def pooled(fn: Any, spec: str, seeds: list[int], workers: int) -> list[Any]:
    """fn(spec, seeds) over `workers` processes, results in seed order."""
    if workers <= 1:
        return list(fn(spec, seeds))
    chunks = [seeds[i::workers] for i in range(workers)]
    # spawned, not forked: a worker forked after torch trained in this process hangs on its thread pool's locks
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        parts = list(pool.map(fn, [spec] * workers, chunks))
    by_seed = {s: r for chunk, part in zip(chunks, parts, strict=True) for s, r in zip(chunk, part, strict=True)}
    return [by_seed[s] for s in seeds]


def lct(args: argparse.Namespace, cache: Path) -> dict[str, Any]:
    import minari

    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.minari_io import write_dataset

    spec = f"participant:{args.participant}"
    name = f"bench/lct-p{args.participant}-n{args.drives}-v0"
    t0 = time.perf_counter()
    if name not in minari.list_local_datasets():
        write_dataset(name, pooled(_episodes, spec, list(range(args.drives)), args.workers))
    seeds = list(range(EVAL_SEED, EVAL_SEED + args.eval))
    ref = cache / f"lct-p{args.participant}-eval{args.eval}.json"
    if not ref.is_file():
        ref.write_text(json.dumps(pooled(_metrics, spec, seeds, args.workers)), encoding="utf-8")
    person = json.loads(ref.read_text(encoding="utf-8"))
    t1 = time.perf_counter()
    config = BCConfig(epochs=args.epochs, history=args.history, actions=args.actions, patience=args.patience)
    summary = train_bc(name, cache / "lct-clone", config)
    t2 = time.perf_counter()
    cloned = pooled(_metrics, f"bc:{cache / 'lct-clone'}", seeds, args.workers)
    out: dict[str, Any] = {
        "participant": spec,
        "history": args.history,
        "actions": args.actions,
        "drives": args.drives,
        "eval_episodes": args.eval,
        "train_steps": summary["steps"],
        "epochs_run": len(summary["loss_per_epoch"]),
        "train_mse": summary["final_mse"],
        "validation_mse": summary.get("validation_mse"),
        "collect_s": t1 - t0,
        "train_s": t2 - t1,
        "eval_s": time.perf_counter() - t2,
    }
    for m in METRICS:
        a = float(np.nanmean([e.get(m, np.nan) for e in person]))
        b = float(np.nanmean([e.get(m, np.nan) for e in cloned]))
        out[m] = {"participant": a, "clone": b, "relative_difference": abs(b - a) / abs(a) if a else float("nan")}
    out["clone_signs_reached"] = float(np.mean([e.get("signs_reached", np.nan) for e in cloned]))
    return out


def countryside(args: argparse.Namespace, cache: Path) -> dict[str, Any]:
    import minari

    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.episodes import collect, load_episode, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent
    from opends_gym.record.cardata import read_cardata

    task = str((DRIVES / "Countryside").resolve())
    logs = sorted((DRIVES / "drives").glob("*/carData*.txt"))
    name = "bench/countryside-v0"
    if name not in minari.list_local_datasets():
        # from each log's own first state; through traffic: the logs began minutes into their sessions
        # (2019_01_04-11_40_24: 107 s), so the env's traffic, started at the task's time 0, is not where OpenDS's was
        write_dataset(name, [load_episode(p, None, task, {"on_collision": "continue"}, trim_idle=True) for p in logs])
    summary = train_bc(name, cache / "cs-clone", BCConfig(epochs=args.cs_epochs, history=args.cs_history, validation=0.0))
    path = np.concatenate([np.c_[c.columns["x_m"], c.columns["z_m"]] for c in map(read_cardata, logs)])
    env = make_env("OpenDS/DrivingTask-v0", {"task": task, "action": "continuous", "max_episode_s": args.seconds})
    longest = max(float(np.hypot(*np.diff(np.c_[c.columns["x_m"], c.columns["z_m"]], axis=0).T).sum()) for c in map(read_cardata, logs))
    out: dict[str, Any] = {"logs": len(logs), "train_steps": summary["steps"], "longest_log_m": longest}
    # the clone, and the rule driver as a reference: how far from the logs' path the road itself leads
    for key, spec in (("clone", f"bc:{cache / 'cs-clone'}"), ("rule", "rule")):
        ep = collect(env, make_agent(spec), 0)
        trace = env.unwrapped.trace
        xz = np.c_[trace.col("x_m"), trace.col("z_m")]
        dist = np.sqrt(((xz[:, None, :] - path[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
        out[key] = {
            "driven_s": float(env.unwrapped.world.t_s),
            "driven_m": float(np.hypot(*np.diff(xz, axis=0).T).sum()),  # a clone that stands still is trivially on the path
            "max_distance_m": float(dist.max()),
            "mean_distance_m": float(dist.mean()),
            "off_road_s": ep.metrics.get("off_road_s", float("nan")),
        }
    env.close()
    return out


def table(result: dict[str, Any], seconds: float) -> list[tuple[str, str, str, bool]]:
    """(check, goal, measured, pass) rows of both acceptance checks."""
    rows = []
    if "lct" in result:
        r = result["lct"]
        for m in METRICS:
            d = r[m]["relative_difference"]
            measured = f"{r[m]['clone']:.3f} vs {r[m]['participant']:.3f} ({d * 100:+.1f} %)".replace("+", "")
            rows.append((f"LCT {m}", "within 15 %", measured, bool(d <= 0.15)))
    if "countryside" in result:
        cs = result["countryside"]
        for key, label in (("clone", "Countryside clone"), ("rule", "(reference: rule driver)")):
            c = cs[key]
            # "drives": at least as far as the longest log drove (a clone that stands still is on the path)
            ok = c["driven_s"] >= seconds - 1e-6 and c["max_distance_m"] <= 5.0 and c["driven_m"] >= cs["longest_log_m"]
            measured = f"{c['driven_s']:.1f} s, {c['driven_m']:.0f} m, max {c['max_distance_m']:.1f} m, mean {c['mean_distance_m']:.1f} m"
            rows.append((label, f"{seconds:.0f} s within 5 m", measured, ok))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--participant", type=int, default=1)
    ap.add_argument("--drives", type=int, default=200)
    ap.add_argument("--eval", type=int, default=20)
    ap.add_argument("--epochs", type=int, default=30, help="LCT clone: most epochs (early stopping on held-out drives)")
    ap.add_argument("--patience", type=int, default=3, help="LCT clone: epochs without a better held-out error before it stops")
    ap.add_argument("--history", type=int, default=15, help="LCT clone: observations it sees (drivers.bc)")
    ap.add_argument("--actions", action=argparse.BooleanOptionalAction, default=False, help="LCT clone: and the actions before them")
    ap.add_argument("--cs-epochs", type=int, default=30, help="Countryside clone: epochs (too few drives to hold any out)")
    ap.add_argument("--cs-history", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "opends-gym-bc-acceptance")
    ap.add_argument("--skip-lct", action="store_true")
    ap.add_argument("--skip-countryside", action="store_true")
    ap.add_argument("--json", action="store_true", help="print the full figures as JSON after the table")
    ap.add_argument("--verbose", action="store_true", help="log each training epoch")
    args = ap.parse_args()
    if args.verbose:  # the trainer's epochs only
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("%(asctime)s %(message)s"))
        logging.getLogger("opends_gym.data.bc").addHandler(handler)
        logging.getLogger("opends_gym.data.bc").setLevel(logging.INFO)
    args.cache = args.cache / source_key()  # stale drives (another model or env) are never reused
    args.cache.mkdir(parents=True, exist_ok=True)
    os.environ["MINARI_DATASETS_PATH"] = str(args.cache / "minari")
    start = time.perf_counter()
    result: dict[str, Any] = {}
    if not args.skip_countryside:
        result["countryside"] = countryside(args, args.cache)
    if not args.skip_lct:
        result["lct"] = lct(args, args.cache)
    result["wall_s"] = time.perf_counter() - start
    rows = table(result, args.seconds)
    width = max(len(r[0]) for r in rows) if rows else 5
    print(f"{'check':<{width}}  {'goal':<18}  {'measured':<44}  pass")
    for check, goal, measured, ok in rows:
        print(f"{check:<{width}}  {goal:<18}  {measured:<44}  {'yes' if ok else 'NO'}")
    print(f"wall {result['wall_s']:.0f} s (cache {args.cache})")
    if args.json:
        print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
