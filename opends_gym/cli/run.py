"""`opends-gym run ENV_OR_TASK --agent ...`: drive episodes and print the metrics.

ENV_OR_TASK is an env id (`OpenDS/LaneChangeTest-v0`, or just `LaneChangeTest`) or a
task (folder, entry file, bundled name), which runs in `OpenDS/DrivingTask-v0`. A
misspelt id, agent or `--env-arg` option is one line on stderr naming the closest match.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym

from ..errors import UserError
from ..jsonsafe import dump_json
from ..metrics.stats import mean_ci
from .episode_table import sd, table_lines, write_csv
from .progress import ProgressBar
from .targets import parse_env_args, parse_value, resolve_env_id

__all__ = ["resolve_env_id", "run_episodes"]

_parse_value = parse_value  # `drive` and `train` parse KEY=VALUE with it
PER_ITEM = re.compile(r"^sign\d+_|\[")  # per-sign / per-track keys stay in the JSON and CSV only


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("target", nargs="?", default="OpenDS/LaneChangeTest-v0", help="env id or task (default: the lane change test)")
    p.add_argument(
        "--agent",
        default="rule",
        help="rule (default) | distracted[:LEVEL] | ppo:NAME|PATH | sac:NAME|PATH (NAME: opends-gym list --policies)"
        " | bc:FOLDER (opends-gym train bc) | random | constant[:STEER,PEDAL]",
    )
    p.add_argument("--episodes", type=int, default=1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--physics", choices=("fast", "bullet"), default="fast")
    p.add_argument("--max-seconds", type=positive_float, default=None, help="simulated seconds per episode (truncates)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="write one row per episode (env, task, agent, seed, episode, metrics)")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: on a terminal with more than one episode; never with --json)",
    )
    p.add_argument("--env-arg", action="append", default=[], metavar="KEY=VALUE", help="extra env option (repeatable)")
    p.add_argument("--record", default=None, metavar="PATH.mcap", help="record each episode to MCAP (never overwrites: name(2).mcap, ...)")
    p.add_argument("--record-rate", type=positive_float, default=None, metavar="HZ", help="ego state rate in recordings (default: physics)")
    add_video_arguments(p)


def add_video_arguments(p: argparse.ArgumentParser) -> None:
    """`--record-video [RATE_HZ]` and `--video-format` (shared by run and drive)."""
    p.add_argument(
        "--record-video",
        type=positive_float,
        nargs="?",
        const=VIDEO_HZ,
        default=None,
        metavar="RATE_HZ",
        help=f"with --record: also record the driver's view as foxglove.CompressedImage (default rate {VIDEO_HZ:g} Hz)",
    )
    p.add_argument("--video-format", choices=("png", "jpeg"), default="png", help="image format of --record-video (default png)")


VIDEO_HZ = 10.0  # --record-video without a rate


def positive_float(text: str) -> float:
    """argparse type: a number above zero (argparse turns the ValueError into one line)."""
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a number above 0, not {text}")
    return value


class CheckedAgent:
    """An agent whose `reset` refusal (a policy trained on another observation shape) is a UserError."""

    def __init__(self, agent: Any, spec: str) -> None:
        self.agent = agent
        self.spec = spec
        self.name = getattr(agent, "name", spec)
        self.act = agent.act

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        try:
            self.agent.reset(env, seed)
        except ValueError as e:
            raise UserError(f"--agent {self.spec}: {e}") from None


def make_cli_agent(spec: str) -> Any:
    """`--agent SPEC` -> agent; a bad name, argument or policy file is a UserError."""
    import zipfile

    from ..drivers.agents import make_agent

    try:
        return CheckedAgent(make_agent(spec), spec)
    except FileNotFoundError as e:
        raise UserError(f"--agent {spec}: {e.strerror or e}") from None
    except (ValueError, TypeError, OSError, zipfile.BadZipFile) as e:
        raise UserError(f"--agent {spec}: {e}") from None


def make_cli_env(env_id: str, kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """`gym.make` whose option errors (a bad value the env rejects) are UserErrors."""
    try:
        return gym.make(env_id, **kwargs)
    except (TypeError, ValueError) as e:
        raise UserError(f"{env_id}: {e}") from None


def run_episodes(args: argparse.Namespace, progress: ProgressBar | None = None) -> dict[str, Any]:
    from ..drivers.episodes import run_episode

    if args.episodes < 1:
        raise UserError(f"--episodes must be at least 1, not {args.episodes}")
    if getattr(args, "record_video", None) is not None and not getattr(args, "record", None):
        raise UserError("--record-video needs --record OUT.mcap (the images go into the recording)")
    env_id, kwargs = resolve_env_id(args.target)
    kwargs["physics"] = args.physics
    if args.max_seconds is not None:
        kwargs["max_episode_s"] = args.max_seconds
    kwargs.update(parse_env_args(args.env_arg, env_id))
    agent = make_cli_agent(args.agent)
    for k, v in getattr(agent.agent, "env_kwargs", {}).items():  # a clone's observation options (e.g. road_preview_m)
        kwargs.setdefault(k, v)
    env = make_cli_env(env_id, kwargs)
    if getattr(args, "record", None):
        from ..record import RecordDrive

        video = getattr(args, "record_video", None)
        env = RecordDrive(
            env,
            args.record,
            rate_hz=getattr(args, "record_rate", None),
            video_rate_hz=video,
            video_format=getattr(args, "video_format", "png"),
        )
    task = getattr(getattr(env.unwrapped, "task", None), "name", "")
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
            if progress is not None:
                progress.update(k + 1, f"return {ep.ret:.4g}")
    finally:
        if progress is not None:
            progress.close()
        env.close()
    keys = [k for k in episodes[0] if k not in ("episode", "seed", "terminated", "recording") and not PER_ITEM.search(k)]
    summary = {}
    for key in keys:
        values = [e[key] for e in episodes if isinstance(e.get(key), (int, float))]
        ci = mean_ci(float(v) for v in values)
        summary[key] = {"mean": ci.mean, "low": ci.low, "high": ci.high, "n": ci.n, "sd": sd(values)}
    return {"env_id": env_id, "task": task, "env_kwargs": kwargs, "agent": args.agent, "episodes": episodes, "summary": summary}


def print_tables(result: dict[str, Any]) -> None:
    print("\n".join(table_lines(result)))


def run(args: argparse.Namespace) -> int:
    if args.csv and Path(args.csv).is_dir():
        raise UserError(f"--csv {args.csv}: is a folder; give a file name such as {Path(args.csv) / 'runs.csv'}")
    if args.csv and not Path(args.csv).resolve().parent.is_dir():
        raise UserError(f"--csv {args.csv}: the folder {Path(args.csv).resolve().parent} does not exist")
    show = False if args.json else args.progress
    result = run_episodes(args, ProgressBar(args.episodes, enabled=show))
    if args.json:
        dump_json(result, sys.stdout)
    else:
        print_tables(result)
        for e in result["episodes"]:
            if "recording" in e:
                print(f"recorded episode {e['episode']}: {e['recording']}")
    if args.csv:
        print(f"wrote {write_csv(result, args.csv)}", file=sys.stderr if args.json else sys.stdout)
    return 0
