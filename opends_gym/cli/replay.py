"""`opends-gym replay REC.mcap [--check] [--at SECONDS]`: re-simulate a recorded drive.

Without options it re-simulates the drive and checks it (as `--check`). `--at T` stops
at simulation time T and prints the world as it was then. Exit status 1 when the check
finds a difference (the first one is printed), 2 when the file cannot be replayed.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from typing import Any


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", help="an MCAP drive recording (opends-gym run --record, RecordDrive, DriveRecorder)")
    p.add_argument("--check", action="store_true", help="assert every recorded state is reproduced exactly (the default)")
    p.add_argument("--at", type=float, default=None, metavar="SECONDS", help="stop at this simulation time and print the world state")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--view",
        action="store_true",
        help="play it in a window with the driven path and ideal track (Return plays, arrows step, Esc quits)",
    )


def _plain(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def run(args: argparse.Namespace) -> int:
    from ..record.replay import ReplayError, describe_state, replay

    if args.view:  # keys: opends_gym.human.replay_view
        from ..human.replay_view import view_recording

        try:
            return view_recording(args.recording, start_s=args.at or 0.0)
        except (ReplayError, ValueError, OSError) as e:
            print(f"replay: {e}", file=sys.stderr)
            return 2

    try:
        result = replay(args.recording, check=True, until_s=args.at)
    except (ReplayError, ValueError, OSError) as e:
        logging.getLogger(__name__).debug("replay failed", exc_info=True)
        print(f"replay: {e}", file=sys.stderr)
        return 2
    rec = result.recording
    meta = rec.meta
    state = describe_state(result.world) if args.at is not None else None
    out = {
        "recording": str(rec.path),
        "complete_file": rec.complete,
        "env_id": meta.get("env_id") or None,
        "task": meta.get("task_name"),
        "seed": meta.get("seed"),
        "inputs_fed": result.inputs_fed,
        "sim_time_s": result.world.t_s,
        "checked": result.checked,
        "exact": result.ok,
        "first_mismatch": str(result.mismatch) if result.mismatch else None,
        "warnings": result.warnings,
        "state": {k: _plain(v) for k, v in state.items()} if state else None,
    }
    result.close()
    if args.json:
        print(json.dumps(out, indent=1))
        return 0 if result.ok else 1
    source = out["env_id"] or f"World of task {out['task']}"
    how = "complete file" if rec.complete else "file cut short at its last flush"
    print(f"replay {rec.path}: {source}, seed {out['seed']}, {result.inputs_fed} inputs, {result.world.t_s:.3f} s simulated ({how})")
    for w in result.warnings:
        print(f"warning: {w}")
    counts = ", ".join(f"{n} {topic}" for topic, n in result.checked.items() if n)
    if result.ok:
        print(f"check: EXACT -- {counts} messages reproduced bit for bit")
    else:
        print(f"check: MISMATCH -- {result.mismatch}")
    if state:
        print(f"world at t = {state['t_s']:.3f} s:")
        for k, v in state.items():
            print(f"  {k:18s} {v}")
    return 0 if result.ok else 1
