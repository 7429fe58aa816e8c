"""The `start_pose` reset option: an episode that starts where a recorded drive started.

Why: a drive log (an OpenDS `carData.txt`) that begins part way along the road re-driven from
the task's start pose puts the driver's actions on the wrong road: the car leaves it within
seconds. `env.reset(options={"start_pose": {...}})` puts the car in the log's first state
instead, the way `opends-gym conform` restarts it from a recorded row (`EgoCar.reset_to`:
pose, forward speed, the automatic's gear and rpm for it; cruise control off).

Keys (OpenDS world frame, as carData logs them): x, y, z (m), yaw_rad (this package's yaw,
`record.messages.yaw_from_jme_quaternion`), speed_mps (>= 0, default 0) and engine_on
(default: as the task starts it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..errors import UserError

REQUIRED = ("x", "y", "z", "yaw_rad")
OPTIONAL = ("speed_mps", "engine_on")
MAX_SPEED_MPS = 100.0  # 360 km/h: beyond any car OpenDS drives, a value this large is a unit slip


@dataclass(frozen=True)
class StartPose:
    """A validated `start_pose` reset option."""

    x: float
    y: float
    z: float
    yaw_rad: float
    speed_mps: float = 0.0
    engine_on: bool | None = None


def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise UserError(f"reset option start_pose: {key} must be a finite number, not {value!r}")
    return float(value)


def parse_start_pose(options: dict[str, Any] | None) -> StartPose | None:
    """The `start_pose` in reset `options` (None when absent); a one-line UserError on bad values."""
    if not options or options.get("start_pose") is None:
        return None
    raw = options["start_pose"]
    if not isinstance(raw, dict):
        raise UserError(f"reset option start_pose must be a dict with {', '.join(REQUIRED)}, not {type(raw).__name__}")
    unknown = sorted(set(raw) - set(REQUIRED) - set(OPTIONAL))
    if unknown:
        raise UserError(f"reset option start_pose: unknown key {unknown[0]!r} (keys: {', '.join(REQUIRED + OPTIONAL)})")
    missing = [k for k in REQUIRED if k not in raw]
    if missing:
        raise UserError(f"reset option start_pose: {missing[0]} is missing (needs {', '.join(REQUIRED)})")
    x, y, z, yaw = (_number(k, raw[k]) for k in REQUIRED)
    speed = _number("speed_mps", raw.get("speed_mps", 0.0))
    if not 0.0 <= speed <= MAX_SPEED_MPS:
        raise UserError(f"reset option start_pose: speed_mps must be within 0..{MAX_SPEED_MPS:g} m/s, not {speed:g}")
    engine = raw.get("engine_on")
    if engine is not None and not isinstance(engine, bool):
        raise UserError(f"reset option start_pose: engine_on must be true or false, not {engine!r}")
    return StartPose(x, y, z, yaw, speed, engine)
