"""`opends-gym conform LOG --task TASK [--physics fast|bullet] [--json] [--trace OUT.csv]`.

Replays a real OpenDS drive log (carData.txt) open loop through our vehicle model, from the
recorded state every 5 s and over the whole run, and prints the errors against the goals
(`record.conform`). Exit status 0 when the goals are met (or do not apply: a log shorter
than 20 s), 1 when they are missed, 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("log", help="OpenDS carData.txt")
    p.add_argument("--task", required=True, help="the driving task the log was driven on (folder or entry XML)")
    p.add_argument("--physics", choices=("fast", "bullet"), default="fast", help="vehicle backend (default fast)")
    p.add_argument("--window", type=float, default=5.0, metavar="S", help="restart from the recorded state every S seconds")
    p.add_argument("--trace", default=None, metavar="OUT.csv", help="whole-run open loop: t_s, x_m, z_m, yaw_rad, speed_kmh")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")


def run(args: argparse.Namespace) -> int:
    from ..record.conform import conform

    try:
        result = conform(args.log, args.task, physics=args.physics, window_s=args.window, trace=args.trace)
    except (ValueError, OSError, KeyError) as e:
        print(f"conform: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result))
    else:
        for k, v in result.items():
            print(f"{k}: {v}")
    return 1 if result["passed"] is False else 0
