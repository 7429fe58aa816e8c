"""`opends-gym drive TASK_OR_ENV --input ...`: a person drives in real time.

The session steps the same env an agent would (so the metrics are the same) and records
it like an agent's run (`--record`); see `opends_gym.human.runner`. Keys follow OpenDS
(arrows drive, Space brakes, P pauses, G reports a reaction, Escape ends the drive;
settings.xml `controllers/keyboard` remaps them).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..jsonsafe import dump_json
from .run import add_video_arguments, positive_float
from .targets import parse_env_args, resolve_env_id


def port(text: str) -> int:
    """argparse type: a TCP port number (0 lets the system choose)."""
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port number 0..65535, not {text}")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("target", nargs="?", default="OpenDS/LaneChangeTest-v0", help="env id or task (default: the lane change test)")
    p.add_argument(
        "--input",
        action="append",
        default=[],
        metavar="SPEC",
        help="keyboard | joystick | can-tcp[:HOST:PORT] | can-bus[:IFACE:CHANNEL] (repeatable; default keyboard)",
    )
    p.add_argument("--record", metavar="OUT.mcap", help="record the drive (flushed every simulated second)")
    add_video_arguments(p)
    p.add_argument("--driver", metavar="NAME", help="driver name for the recording (default: settings.xml driverName)")
    p.add_argument("--duration", type=positive_float, metavar="SECONDS", help="end after this much simulated time")
    p.add_argument("--no-window", action="store_true", help="run the same loop without a window (scripted sessions, tests)")
    p.add_argument("--fast", action="store_true", help="do not pace to the wall clock")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--physics", choices=("fast", "bullet"), default="fast")
    p.add_argument("--size", default="1280x720", metavar="WxH", help="window size in pixels")
    p.add_argument("--calibration", metavar="FILE", help="wheel/pedal calibration (YAML/JSON, or wheel_calibration: the shipped example)")
    p.add_argument("--dbc", metavar="FILE", help="DBC file for --input can-bus (default: the shipped can_example.dbc)")
    server = p.add_mutually_exclusive_group()
    server.add_argument(
        "--settings-server", dest="settings_server", action="store_true", default=None, help="start the settings-controller server"
    )
    server.add_argument("--no-settings-server", dest="settings_server", action="store_false", help="never start it")
    p.add_argument("--server-host", default="127.0.0.1", help="settings-controller bind address (default 127.0.0.1)")
    p.add_argument("--server-port", type=port, help="settings-controller port (default: settings.xml)")
    p.add_argument(
        "--server-allow", action="append", metavar="ADDRESS", help="only this peer may send control events (repeatable; docs/hardening.md)"
    )
    p.add_argument(
        "--server-token-env", metavar="VAR", help="control events need the token in this environment variable (docs/hardening.md)"
    )
    p.add_argument("--no-audio", action="store_true", help="log sounds without playing them")
    p.add_argument("--screenshot", metavar="OUT.png", help="save the last frame of the window as PNG")
    p.add_argument("--env-arg", action="append", default=[], metavar="KEY=VALUE", help="extra env option (repeatable)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")


def config_from_args(args: argparse.Namespace) -> Any:
    from ..human.session_config import DriveConfig, parse_input_spec

    try:
        w, _, h = str(args.size).lower().partition("x")
        width, height = int(w), int(h)
    except ValueError:
        raise UserError(f"--size must be WIDTHxHEIGHT, not {args.size!r}") from None
    try:
        inputs = tuple(parse_input_spec(s) for s in (args.input or ["keyboard"]))
    except ValueError as e:
        raise UserError(f"--input: {e}") from None
    for option, path in (("--calibration", args.calibration), ("--dbc", args.dbc)):
        if path is not None and not Path(path).is_file():
            raise UserError(f"{option} {path}: no such file")
    if args.record_video is not None and not args.record:
        raise UserError("--record-video needs --record OUT.mcap (the images go into the recording)")
    env_id, _ = resolve_env_id(args.target)  # a misspelt id or task fails here, in one line
    env_kwargs = parse_env_args(args.env_arg, env_id)
    return DriveConfig(
        target=args.target,
        inputs=inputs,
        record_path=args.record,
        record_video_hz=args.record_video,
        video_format=args.video_format,
        driver=args.driver,
        duration_s=args.duration,
        window=not args.no_window,
        fast=args.fast,
        seed=args.seed,
        physics=args.physics,
        width=width,
        height=height,
        calibration=args.calibration,
        dbc=args.dbc,
        settings_server=args.settings_server,
        server_host=args.server_host,
        server_port=args.server_port,
        server_control_peers=tuple(args.server_allow) if args.server_allow else None,
        server_token_env=args.server_token_env,
        audio=not args.no_audio,
        screenshot_path=args.screenshot,
        env_kwargs=env_kwargs,
    )


def summary(result: Any) -> dict[str, Any]:
    times = sorted(result.frame_times_s)
    p95 = times[int(0.95 * (len(times) - 1))] if times else math.nan
    return {
        "env_id": result.env_id,
        "end_reason": result.end_reason,
        "steps": result.steps,
        "sim_time_s": result.sim_time_s,
        "wall_s": result.wall_s,
        "real_time_factor": result.sim_time_s / result.wall_s if result.wall_s > 0 else math.inf,
        "frames": result.frames,
        "mean_fps": result.mean_fps,
        "p95_frame_ms": 1000.0 * p95,
        "dropped_s": result.pacing.dropped_s,
        "held_s": result.pacing.held_s,
        "input_problems": result.input_problems,
        "recordings": result.recordings,
        "sounds": [f"{e.t_s:.3f} {e.op} {e.sound_id}{'' if e.played else ' (not heard)'}" for e in result.sounds],
        "reactions": result.reactions,
        "metrics": result.metrics,
    }


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def run(args: argparse.Namespace) -> int:
    from ..human.runner import DriveSession

    config = config_from_args(args)
    try:
        session = DriveSession(config)
    except (ValueError, RuntimeError) as e:  # a bad option value, port or display (tasks and files: main's one line)
        raise UserError(str(e)) from e
    with session:
        result = session.run()
    out = summary(result)
    if args.json:
        dump_json(out, sys.stdout)
        return 0
    print(f"{out['env_id']}: {out['end_reason']} after {out['sim_time_s']:.2f} s simulated in {out['wall_s']:.2f} s")
    if out["frames"]:
        fps, p95, dropped = out["mean_fps"], out["p95_frame_ms"], out["dropped_s"]
        print(f"frames {out['frames']}  mean {fps:.1f} fps  p95 frame {p95:.1f} ms  lag dropped {dropped:.2f} s")
    for path in out["recordings"]:
        print(f"recording: {path}")
    width = max((len(k) for k in out["metrics"]), default=10) + 2
    for k, v in out["metrics"].items():
        print(k.ljust(width) + _fmt(v))
    return 0
