"""Behaviour-cloning acceptance (issue 22): how close a clone drives to the drives it was cloned from.

1. LCT: --drives episodes of virtual participant --participant (baseline load) on the Lane Change
   Test become a Minari dataset; a clone is trained on it; over --eval new seeds (10000 on, never
   trained on) the clone's and the participant's mean MDEV (mdev_basic_m), SDLP (sdlp_m) and
   lane-change latency (mean_lane_change_latency_s) are compared (goal: each within 15 %).
2. Countryside: OpenDS carData.txt logs of the Countryside task go through the same pipeline as a
   lab's (`opends-gym export LOGS --task Countryside --trim-idle --minari`, each log from its own
   first state at its first gas, through traffic; `train bc`; `--agent bc:`), and the clone drives
   the task from its start for --seconds (60). The figure is the largest distance from the clone's
   path to the paths those logs recorded (goal: 5 m); a clone that leaves the road early fails,
   and so does one that ends more than 5 m short of where the logs got in that time (the least far
   of the logs that lasted it; where none did, the longest: one that stands still is trivially on
   the path). Then, over what the logs cover, the clone drives from each log's first state for as
   long as that log drove (at most --seconds): within 5 m throughout and no more than 5 m short.
   The logs: the real ones bundled in tests/data/opends-drives (about 25 s of moving in all: 60 s
   is beyond them), the carData*.txt under --countryside-logs DIR, or --synthetic-countryside N:
   N drives of virtual participant --cs-participant (seeds 0..N-1, --seconds + --cs-extra-s long)
   recorded and written as carData.txt by our writer (`opends-gym analyze --export-opends`).
   The rule driver's row is a reference: where the road leads away from the logs' paths (the
   bundled ones cover parts of it only), no driver that follows it stays within 5 m.

Drives are collected in a process pool (--workers) and cached under --cache (the Minari datasets
and the participant's evaluation metrics), so a second run only trains and evaluates the clones.
The cache sits in a folder named by `source_key()`: a hash of the package's version, this script and
every source file of opends_gym (env, participant model, export) and of the bundled drives, so a change to
any of them collects the drives anew instead of reusing stale ones.
Prints one table (goal, measured, pass) and, with --json, the full figures.

    PYTHONPATH=. python benchmarks/bc_acceptance.py                      # the acceptance (200 drives, 20 episodes)
    PYTHONPATH=. python benchmarks/bc_acceptance.py --drives 20 --eval 4 # a quick look
    PYTHONPATH=. python benchmarks/bc_acceptance.py --skip-lct --synthetic-countryside 10  # Countryside from 75 s logs
    PYTHONPATH=. python benchmarks/bc_acceptance.py --skip-lct --cs-augment recovery --cs-history 1 --cs-lateral 3 \
        --cs-dart 8 --cs-tau 1 --cs-epochs 300 --cs-augment-every 0.25 --cs-seeds 0,1,2,3,4   # few short real logs, 5 seeds

--cs-seeds trains one clone per seed and checks each: how much a result hangs on the training seed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import multiprocessing
import os
import shutil
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DRIVES = ROOT / "tests" / "data" / "opends-drives"
LCT = "OpenDS/LaneChangeTest-v0"
METRICS = ("mdev_basic_m", "sdlp_m", "mean_lane_change_latency_s")
EVAL_SEED = 10_000  # evaluation seeds start here; training drives use 0..drives-1
GOAL_M = 5.0  # issue 22: within 5 m of the path the drives took
CS_TASK = (DRIVES / "Countryside").resolve()
CS_EXPORT = {"on_collision": "continue"}  # how carData logs are exported and their spans re-driven (see countryside())


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


def synthetic_logs(folder: Path, n: int, seconds: float, spec: str, workers: int) -> list[Path]:
    """`n` carData.txt logs of agent `spec` driving the Countryside task for `seconds` from its start
    (seeds 0..n-1): each drive recorded (`record.wrapper.RecordDrive`) and exported with our carData
    writer (`record.export.export_opends`, what `opends-gym analyze --export-opends` writes)."""
    logs = [folder / f"seed{s}" / "carData.txt" for s in range(n)]
    todo = [s for s, p in enumerate(logs) if not p.is_file()]
    if todo:
        pooled(partial(_write_logs, folder, seconds), spec, todo, workers)
    return logs


def _write_logs(folder: Path, seconds: float, spec: str, seeds: list[int]) -> list[Path]:
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.drivers.agents import make_agent
    from opends_gym.record.drive import load_drive
    from opends_gym.record.export import export_opends
    from opends_gym.record.wrapper import RecordDrive

    out = []
    for seed in seeds:
        env = RecordDrive(make_env("OpenDS/DrivingTask-v0", {"task": str(CS_TASK), "max_episode_s": seconds}), folder / f"seed{seed}.mcap")
        collect(env, make_agent(spec), seed)
        env.close()
        shutil.rmtree(folder / f"seed{seed}", ignore_errors=True)  # a run cut short mid-export
        out.append(export_opends(load_drive(env.paths[0]), folder / f"seed{seed}")[0])
        env.paths[0].unlink()
    return out


def logs_key(logs: list[Path]) -> str:
    """8 hex digits naming the logs' contents (the dataset cloned from them)."""
    h = hashlib.sha256()
    for p in logs:
        h.update(p.read_bytes())
    return h.hexdigest()[:8]


def logs_path(logs: list[Path], step_m: float = 0.25) -> Any:
    """A KD-tree of the paths the logs recorded, each polyline filled in every `step_m` metres
    (rows 50 ms apart are over 1 m apart at speed: their nearest row would overstate the distance)."""
    from scipy.spatial import cKDTree

    from opends_gym.record.cardata import read_cardata

    parts = []
    for c in map(read_cardata, logs):
        xz = np.c_[c.columns["x_m"], c.columns["z_m"]]
        s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xz, axis=0).T))]
        at = np.arange(0.0, s[-1] + step_m, step_m) if s[-1] > 0 else np.zeros(1)
        parts.append(np.c_[np.interp(at, s, xz[:, 0]), np.interp(at, s, xz[:, 1])])
    return cKDTree(np.concatenate(parts))


def log_start(path: Path) -> tuple[dict[str, Any], float, np.ndarray, np.ndarray]:
    """Where a log's drive starts as the export starts it (its first settled row from its first gas,
    `data.episodes.from_cardata` with trim_idle: the `start_pose` option), the seconds from there
    to its end, and per row from there the seconds and the distance driven."""
    from opends_gym.data.episodes import NeverSetsOff, cardata_start_pose, cardata_start_row
    from opends_gym.record.conform import Recorded

    r = Recorded(path)
    try:
        i0 = cardata_start_row(r, trim_idle=True)
    except NeverSetsOff:
        i0 = r.n - 1  # nothing from there: no span
    t = r.sim_t[i0:] - r.sim_t[i0]
    d = np.r_[0.0, np.cumsum(np.hypot(np.diff(r.x[i0:]), np.diff(r.z[i0:])))]
    return cardata_start_pose(r, i0), float(t[-1]), t, d


def reach_m(logs: list[Path], seconds: float) -> float:
    """How far the logs drove, the distance the clone must drive in `seconds`: the least any log
    that lasted `seconds` from its start (`log_start`) drove in them; where none lasted that long
    (the bundled logs), the longest any log drove."""
    spans = [log_start(p) for p in logs]
    full = [float(np.interp(seconds, t, d)) for _, span, t, d in spans if span >= seconds]
    return min(full) if full else max(float(d[-1]) for *_, d in spans)


def drive_clone(
    spec: str, tree: Any, seconds: float, env_kwargs: dict[str, Any], start_pose: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Agent `spec` on the Countryside task for `seconds` (from the task's start or `start_pose`):
    how long and far it drove and its largest and mean distance from the logs' path."""
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.drivers.agents import make_agent

    agent = make_agent(spec)
    clone_kwargs = getattr(agent, "env_kwargs", {})  # a clone's observation options (road_preview_m), as `run --agent bc:` makes the env
    kwargs = {"task": str(CS_TASK), "action": "continuous", "max_episode_s": seconds, **clone_kwargs, **env_kwargs}
    env = make_env("OpenDS/DrivingTask-v0", kwargs)
    base: Any = env.unwrapped
    try:
        if start_pose is None:
            metrics = collect(env, agent, 0).metrics
        else:  # collect() resets without options: step by hand from the log's first state
            obs, info = env.reset(seed=0, options={"start_pose": start_pose})
            agent.reset(env, 0)
            done = False
            while not done:
                obs, _, terminated, truncated, info = env.step(np.asarray(agent.act(obs, info), dtype=np.float32))
                done = terminated or truncated
            metrics = info.get("episode_metrics", {})
        xz = np.c_[base.trace.col("x_m"), base.trace.col("z_m")]
        dist = tree.query(xz)[0]
        return {
            "driven_s": float(base.world.t_s),
            "driven_m": float(np.hypot(*np.diff(xz, axis=0).T).sum()),  # a clone that stands still is trivially on the path
            "max_distance_m": float(dist.max()),
            "mean_distance_m": float(dist.mean()),
            "off_road_s": float(metrics.get("off_road_s", float("nan"))),
        }
    finally:
        env.close()


def countryside_logs(args: argparse.Namespace, cache: Path) -> tuple[str, list[Path]]:
    """The logs to clone from and what they are: --synthetic-countryside, --countryside-logs or the bundled ones."""
    if args.synthetic_countryside:
        spec = f"participant:{args.cs_participant}"
        secs = args.seconds + args.cs_extra_s
        folder = cache / f"synthetic-p{args.cs_participant.replace(':', '-')}-{secs:g}s"
        label = f"{args.synthetic_countryside} drives of {spec}, {secs:g} s each, as carData.txt"
        return label, synthetic_logs(folder, args.synthetic_countryside, secs, spec, args.workers)
    if args.countryside_logs:
        logs = sorted(Path(args.countryside_logs).rglob("carData*.txt"))
        if not logs:
            raise SystemExit(f"{args.countryside_logs}: no carData*.txt logs under it")
        return f"{len(logs)} logs under {args.countryside_logs}", logs
    return "the bundled real OpenDS logs", sorted((DRIVES / "drives").glob("*/carData*.txt"))


def _export_logs(logs: list[Path], export: dict[str, Any], augment: str, indices: list[int]) -> list[list[Any]]:
    """The episodes of logs[i] for each index as `opends-gym export --trim-idle [--augment]` makes them
    (none where a log never sets off: export skips it); a pool worker's share."""
    from opends_gym.data.episodes import NeverSetsOff, load_episode
    from opends_gym.data.recovery import RecoveryConfig, cardata_with_recovery

    out: list[list[Any]] = []
    for i in indices:
        try:
            if augment.startswith("recovery:"):  # recovery:EVERY_S:DRAWS:DART:LATERAL_M:TAU_S
                every, draws, dart, lateral, tau = augment.split(":")[1:]
                config = RecoveryConfig(every_s=float(every), draws=int(draws), dart=int(dart), lateral_m=float(lateral), tau_s=float(tau))
                out.append(cardata_with_recovery(logs[i], None, str(CS_TASK), export, trim_idle=True, config=config))
            else:
                out.append([load_episode(logs[i], None, str(CS_TASK), export, trim_idle=True)])
        except NeverSetsOff:
            out.append([])
    return out


def countryside(args: argparse.Namespace, cache: Path) -> dict[str, Any]:
    import minari

    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.minari_io import write_dataset

    t0 = time.perf_counter()
    label, logs = countryside_logs(args, cache)
    preview = tuple(float(v) for v in args.cs_preview.split(",") if v.strip())
    export = {**CS_EXPORT, "road_preview_m": preview} if preview else CS_EXPORT  # the dataset's env spec: the clone's env
    key = logs_key(logs) + ("-preview-" + "-".join(f"{d:g}" for d in preview) if preview else "")
    copy = (args.cs_augment_every, args.cs_draws, args.cs_dart, args.cs_lateral, args.cs_tau)
    copies = "{:g}s-{}x-dart{}-{:g}m-{:g}s".format(*copy).replace(".", "p")
    key += f"-{args.cs_augment}-{copies}" if args.cs_augment else ""
    name = f"bench/countryside-{key}-v0"
    if name not in minari.list_local_datasets():
        # from each log's own first state at its first gas; through traffic: the real logs began minutes into their
        # sessions (2019_01_04-11_40_24: 107 s), so the env's traffic, started at the task's time 0, is not where OpenDS's was
        augment = ":".join(map(str, (args.cs_augment, *copy))) if args.cs_augment else ""
        exported = pooled(partial(_export_logs, logs, export), augment, list(range(len(logs))), args.workers)
        episodes = [ep for eps in exported for ep in eps]
        write_dataset(name, episodes)
    t1 = time.perf_counter()
    tree = logs_path(logs)
    augment = (
        f"{args.cs_augment} every {args.cs_augment_every:g} s, {args.cs_draws} per start up to {args.cs_lateral:g} m across,"
        f" {args.cs_dart} DART rollouts, labels within {args.cs_tau:g} s"
    )
    out: dict[str, Any] = {
        "logs": label,
        "log_files": len(logs),
        "history": args.cs_history,
        "epochs": args.cs_epochs,
        "ensemble": args.cs_ensemble,
        "road_preview_m": list(preview),
        "augment": augment if args.cs_augment else "",
        "reach_m": reach_m(logs, args.seconds),
        "collect_s": t1 - t0,
        # the rule driver as a reference: how far from the logs' path the road itself leads
        "rule": drive_clone("rule", tree, args.seconds, {}),
        "seeds": [],
    }
    for seed in args.cs_seeds:  # one clone per training seed: how much the result hangs on it
        t2 = time.perf_counter()
        clone = cache / f"cs-clone-{key}-h{args.cs_history}-e{args.cs_epochs}-x{args.cs_ensemble}-s{seed}"
        config = BCConfig(epochs=args.cs_epochs, history=args.cs_history, validation=0.0, seed=seed, ensemble=args.cs_ensemble)
        summary = train_bc(name, clone, config)
        t3 = time.perf_counter()
        run = {"seed": seed, "train_steps": summary["steps"], "train_s": t3 - t2}
        run["clone"] = drive_clone(f"bc:{clone}", tree, args.seconds, {})
        # over what the logs cover: the clone from each log's first state for as long as the log drove (through traffic)
        spans = []
        for p in logs:
            pose, span, t, d = log_start(p)
            if span * 10.0 < 1.0 or d[-1] < 1.0:  # not one policy step, or it never set off: nothing to follow
                continue
            secs = min(span, args.seconds)
            row = drive_clone(f"bc:{clone}", tree, secs, CS_EXPORT, pose)
            spans.append({"log": str(p.relative_to(p.parents[1])), "span_s": secs, "log_m": float(np.interp(secs, t, d)), **row})
        run["spans"] = spans
        run["eval_s"] = time.perf_counter() - t3
        out["seeds"].append(run)
    out["train_steps"] = out["seeds"][0]["train_steps"]
    return out


def clone_ok(c: dict[str, Any], seconds: float, reach: float) -> bool:
    """The goal: `seconds` driven, within 5 m of the logs' path throughout, no more than 5 m short of
    where the logs got (a clone that stands still is trivially on the path)."""
    return c["driven_s"] >= seconds - 1e-6 and c["max_distance_m"] <= GOAL_M and c["driven_m"] >= reach - GOAL_M


def spans_ok(spans: list[dict[str, Any]]) -> bool:
    """Each log's span driven whole, within 5 m of the logs' path and no more than 5 m short of the log."""
    return all(s["driven_s"] >= s["span_s"] - 0.1 and s["max_distance_m"] <= GOAL_M and s["driven_m"] >= s["log_m"] - GOAL_M for s in spans)


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
        many = len(cs["seeds"]) > 1
        tag = {r["seed"]: f" (seed {r['seed']})" if many else "" for r in cs["seeds"]}
        drives = [(f"Countryside clone{tag[r['seed']]}", r["clone"]) for r in cs["seeds"]]
        for label, c in [*drives, ("(reference: rule driver)", cs["rule"])]:
            measured = (
                f"{c['driven_s']:.1f} s, {c['driven_m']:.0f} m (logs {cs['reach_m']:.0f} m),"
                f" max {c['max_distance_m']:.1f} m, mean {c['mean_distance_m']:.1f} m"
            )
            rows.append((label, f"{seconds:.0f} s within 5 m", measured, clone_ok(c, seconds, cs["reach_m"])))
        for r in cs["seeds"]:
            spans = r["spans"]
            if not spans:
                continue
            driven, logged = sum(s["driven_m"] for s in spans), sum(s["log_m"] for s in spans)
            measured = (
                f"{len(spans)} logs: {sum(s['driven_s'] for s in spans):.1f} of {sum(s['span_s'] for s in spans):.1f} s,"
                f" {driven:.0f} of {logged:.0f} m, max {max(s['max_distance_m'] for s in spans):.1f} m"
            )
            rows.append((f"Countryside clone over each log's span{tag[r['seed']]}", "each within 5 m", measured, spans_ok(spans)))
        if many:
            n = len(cs["seeds"])
            goal = sum(clone_ok(r["clone"], seconds, cs["reach_m"]) for r in cs["seeds"])
            each = sum(spans_ok(r["spans"]) for r in cs["seeds"] if r["spans"])
            measured = f"{seconds:.0f} s goal: {goal}, every span: {each}"
            rows.append(("Countryside clones: training seeds that pass", f"of {n}", measured, goal == n))
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
    ap.add_argument("--cs-history", type=int, default=15, help="Countryside clone: observations it sees")
    logs = ap.add_mutually_exclusive_group()
    logs.add_argument(
        "--countryside-logs", type=Path, metavar="DIR", help="clone from the carData*.txt logs under DIR (default: the bundled ones)"
    )
    logs.add_argument("--synthetic-countryside", type=int, default=0, metavar="N", help="clone from N carData logs of --cs-participant")
    ap.add_argument("--cs-participant", default="1", help="--synthetic-countryside: the virtual participant who drives, ID[:LOAD]")
    ap.add_argument(
        "--cs-extra-s", type=float, default=15.0, help="--synthetic-countryside: the logs drive this much longer than --seconds"
    )
    ap.add_argument(
        "--cs-preview",
        default="10,25,50",
        metavar="D,...",
        help="Countryside: the road preview the logs are exported with (env road_preview_m, metres; '' for none)",
    )
    ap.add_argument(
        "--cs-augment",
        choices=("recovery",),
        default=None,
        help="Countryside: export with --augment recovery (perturbed copies labelled with the way back, data.recovery)",
    )
    ap.add_argument(
        "--cs-augment-every", type=float, default=1.0, metavar="S", help="--cs-augment recovery: a copy every S seconds of each log"
    )
    ap.add_argument(
        "--cs-draws", type=int, default=1, metavar="N", help="--cs-augment recovery: N copies per start point (export --augment-draws)"
    )
    ap.add_argument(
        "--cs-dart", type=int, default=0, metavar="N", help="--cs-augment recovery: N noisy rollouts of each log (export --augment-dart)"
    )
    ap.add_argument("--cs-lateral", type=float, default=1.5, metavar="M", help="--cs-augment recovery: copies start up to M m across")
    ap.add_argument("--cs-tau", type=float, default=2.0, metavar="S", help="--cs-augment recovery: labels rejoin the log within S s")
    ap.add_argument("--cs-ensemble", type=int, default=1, metavar="N", help="Countryside clone: N networks averaged (train bc --ensemble)")
    ap.add_argument(
        "--cs-seeds",
        type=lambda v: [int(x) for x in v.split(",")],
        default=[0],
        metavar="S,...",
        help="Countryside: one clone per training seed, each driven and checked (default 0)",
    )
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
    if "countryside" in result:
        cs = result["countryside"]
        aug = f", augmented: {cs['augment']} ({cs['train_steps']} training steps)" if cs["augment"] else ""
        print(f"Countryside: cloned from {cs['logs']}, road preview {cs['road_preview_m'] or 'none'} m{aug}")
        print(f"Countryside clone: history {cs['history']}, {cs['epochs']} epochs, ensemble of {cs['ensemble']}")
    print(f"wall {result['wall_s']:.0f} s (cache {args.cache})")
    if args.json:
        print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
