"""`opends-gym run ENV_OR_TASK --agent ...`: drive episodes and print the metrics.

ENV_OR_TASK is an env id (`OpenDS/LaneChangeTest-v0`, or just `LaneChangeTest`) or a
task (folder, entry file, bundled name), which runs in `OpenDS/DrivingTask-v0`.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import Any

import gymnasium as gym

from ..jsonsafe import dump_json
from ..metrics.stats import mean_ci

PER_ITEM = re.compile(r"^sign\d+_|\[")  # per-sign / per-track keys stay in the JSON only


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("target", nargs="?", default="OpenDS/LaneChangeTest-v0", help="env id or task (default: the lane change test)")
    p.add_argument(
        "--agent", default="rule", help="rule (default) | distracted[:LEVEL] | ppo:PATH | sac:PATH | random | constant[:STEER,PEDAL]"
    )
    p.add_argument("--episodes", type=int, default=1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--physics", choices=("fast", "bullet"), default="fast")
    p.add_argument("--max-seconds", type=float, default=None, help="simulated seconds per episode (truncates)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.add_argument("--env-arg", action="append", default=[], metavar="KEY=VALUE", help="extra env option (repeatable)")
    p.add_argument("--record", default=None, metavar="PATH.mcap", help="record each episode to MCAP (never overwrites: name(2).mcap, ...)")
    p.add_argument("--record-rate", type=float, default=None, metavar="HZ", help="ego state rate in the recording (default: physics rate)")


def resolve_env_id(target: str) -> tuple[str, dict[str, Any]]:
    import opends_gym  # noqa: F401  (registers the ids)

    if target in gym.registry:
        return target, {}
    for candidate in (f"OpenDS/{target}", f"OpenDS/{target}-v0"):
        if candidate in gym.registry:
            return candidate, {}
    return "OpenDS/DrivingTask-v0", {"task": target}


def _parse_value(text: str) -> Any:
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def run_episodes(args: argparse.Namespace) -> dict[str, Any]:
    from ..drivers.agents import make_agent
    from ..drivers.episodes import run_episode

    env_id, kwargs = resolve_env_id(args.target)
    kwargs["physics"] = args.physics
    if args.max_seconds is not None:
        kwargs["max_episode_s"] = args.max_seconds
    for item in args.env_arg:
        key, _, value = item.partition("=")
        kwargs[key] = _parse_value(value)
    agent = make_agent(args.agent)
    env = gym.make(env_id, **kwargs)
    if getattr(args, "record", None):
        from ..record import RecordDrive

        env = RecordDrive(env, args.record, rate_hz=getattr(args, "record_rate", None))
    episodes = []
    try:
        for k in range(args.episodes):
            seed = args.seed + k
            ep = run_episode(env, agent, seed)
            row = {
                "episode": k,
                "seed": seed,
                "return": ep.ret,
                "steps": ep.steps,
                "terminated": ep.terminated,
                "wall_s": ep.wall_s,
            }
            row.update(ep.metrics)
            if "lanes_known" in row:  # (a yes/no: the task defines the lanes the offsets are measured in)
                row["lanes_known"] = bool(row["lanes_known"])
            recorded = getattr(env, "paths", None)  # RecordDrive's files so far
            if recorded:
                row["recording"] = str(recorded[-1])
            episodes.append(row)
    finally:
        env.close()
    keys = [k for k in episodes[0] if k not in ("episode", "seed", "terminated", "recording") and not PER_ITEM.search(k)]
    summary = {}
    for key in keys:
        ci = mean_ci(float(e[key]) for e in episodes if isinstance(e.get(key), (int, float)))
        summary[key] = {"mean": ci.mean, "low": ci.low, "high": ci.high, "n": ci.n}
    return {"env_id": env_id, "env_kwargs": kwargs, "agent": args.agent, "episodes": episodes, "summary": summary}


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def print_tables(result: dict[str, Any]) -> None:
    eps = result["episodes"]
    keys = list(result["summary"])
    print(f"{result['env_id']}  agent={result['agent']}  episodes={len(eps)}")
    width = max(len(k) for k in keys) + 2
    header = "metric".ljust(width) + "".join(f"ep{e['episode']}".rjust(12) for e in eps) + "   mean [95% CI]"
    print(header)
    print("-" * len(header))
    for k in keys:
        s = result["summary"][k]
        ci = (
            ""
            if s["n"] == 0
            else (_fmt(s["mean"]) if s["n"] < 2 or math.isnan(s["low"]) else f"{_fmt(s['mean'])} [{_fmt(s['low'])}, {_fmt(s['high'])}]")
        )
        print(k.ljust(width) + "".join(_fmt(e.get(k, "")).rjust(12) for e in eps) + "   " + ci)


def run(args: argparse.Namespace) -> int:
    result = run_episodes(args)
    if args.json:
        dump_json(result, sys.stdout)
    else:
        print_tables(result)
        for e in result["episodes"]:
            if "recording" in e:
                print(f"recorded episode {e['episode']}: {e['recording']}")
    return 0
