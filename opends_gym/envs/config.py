"""Env configuration: a frozen dataclass with units in the names; typos are errors.

Why: `gymnasium.make("OpenDS/LaneChangeTest-v0", policy_hz=20, physics="bullet")` must
reject `polcy_hz=20` loudly instead of silently training with the default.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from dataclasses import dataclass, field
from typing import Any, TypeVar

from ..hints import meant
from .road_exit import DEFAULT_RESET_HOLD_S

T = TypeVar("T")


@dataclass(frozen=True)
class EnvConfig:
    """Options shared by every OpenDS env (task envs add their own dataclass fields)."""

    physics: str = "fast"  # fast | bullet
    physics_hz: float = 60.0
    policy_hz: float = 10.0
    observation: str = "kinematics"  # kinematics | rays | topdown | driver_view
    action: str = "continuous"  # continuous | continuous_buttons | discrete
    max_episode_s: float = 600.0
    nearby_vehicles: int = 4  # traffic objects in the kinematics observation
    road_preview_m: tuple[float, ...] = ()  # vector observations: the road's heading and the point d m ahead (observations.py)
    rays: int = 24
    ray_range_m: float = 80.0
    image_width: int = 84
    image_height: int = 84
    render_width: int = 640
    render_height: int = 360
    terminate_on_collision: bool = True  # (older switch; on_collision, when set, decides)
    on_collision: str | None = None  # terminate | recover | continue (opends_gym.envs.collision); None: from terminate_on_collision
    on_road_exit: str = "terminate"  # terminate | recover | continue (opends_gym.envs.road_exit)
    reset_hold_s: float = DEFAULT_RESET_HOLD_S  # recover / reset_position(): seconds held still after the reset (ours; OpenDS: none)
    off_road_margin_m: float = 1.5  # beyond the road's edges by this much counts as leaving the road
    reward_speed_weight: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)

    @functools.cached_property
    def action_repeat(self) -> int:
        """Physics steps per policy step (kept: the env asks every policy step)."""
        return max(1, int(round(self.physics_hz / self.policy_hz)))


def build_config(cls: type[T], kwargs: dict[str, Any]) -> T:
    """`cls(**kwargs)` that names the unknown keys and the valid ones on a typo."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(kwargs) - names)
    if unknown:
        hints = "".join(meant(k, names) for k in unknown)
        raise TypeError(f"unknown option(s) {', '.join(unknown)} for {cls.__name__}{hints}; valid: {', '.join(sorted(names))}")
    cfg = cls(**kwargs)
    _validate(cfg)
    return cfg


# Fields that must be positive, and sanity bounds (not OpenDS values: OpenDS steps physics at
# 60 Hz): beyond them one policy step would take minutes or a frame gigabytes.
_POSITIVE = ("physics_hz", "policy_hz", "max_episode_s", "ray_range_m", "image_width", "image_height", "render_width", "render_height")
_UPPER = {"physics_hz": 10_000.0, "image_width": 8192, "image_height": 8192, "render_width": 8192, "render_height": 8192}


def _check_numbers(cfg: Any) -> None:
    """Every number field is a finite number of its default's type (int fields take whole ints)."""
    for f in dataclasses.fields(cfg):
        default = f.default
        if default is dataclasses.MISSING or isinstance(default, bool) or not isinstance(default, (int, float)):
            continue
        value = getattr(cfg, f.name)
        name = type(cfg).__name__
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(f"{name}.{f.name} must be a number, not {value!r}")
        if isinstance(default, int) and not isinstance(value, numbers.Integral):
            raise ValueError(f"{name}.{f.name} must be a whole number, not {value!r}")
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{name}.{f.name} must be finite, not {value!r}")
        if f.name in _POSITIVE and number <= 0:
            raise ValueError(f"{name}.{f.name} must be positive, not {value!r}")
        if f.name == "physics_hz" and number < 1.0:
            raise ValueError(f"{name}.physics_hz must be at least 1 Hz, not {value!r}")
        if isinstance(default, int) and number < 0:
            raise ValueError(f"{name}.{f.name} must not be negative, not {value!r}")
        if f.name in _UPPER and number > _UPPER[f.name]:
            raise ValueError(f"{name}.{f.name} must be at most {_UPPER[f.name]:g}, not {value!r}")


# Farthest road preview: the far point of Salvucci & Gray (2004) lies 1-2 s ahead; 500 m is
# a sanity bound (beyond the routes of most tasks), not a model value.
PREVIEW_MAX_M = 500.0


def check_preview(value: Any) -> tuple[float, ...]:
    """`road_preview_m` as a tuple of distinct distances in (0, PREVIEW_MAX_M] m (a list from a
    JSON env spec, e.g. a Minari dataset's, is accepted)."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)):
        raise ValueError(f"road_preview_m must be a list of distances in metres, e.g. (10.0, 25.0), not {value!r}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not 0.0 < float(v) <= PREVIEW_MAX_M:
            raise ValueError(f"road_preview_m: each distance must be a number in (0, {PREVIEW_MAX_M:g}] m, not {v!r}")
        out.append(float(v))
    if len(set(out)) != len(out):
        raise ValueError(f"road_preview_m: distances must differ, not {value!r}")
    return tuple(out)


def _validate(cfg: Any) -> None:
    if getattr(cfg, "physics", "fast") not in ("fast", "bullet"):
        raise ValueError(f"physics must be 'fast' or 'bullet', not {cfg.physics!r}")
    _check_numbers(cfg)
    if hasattr(cfg, "road_preview_m"):
        object.__setattr__(cfg, "road_preview_m", check_preview(cfg.road_preview_m))  # frozen: normalise once here
        if cfg.road_preview_m and getattr(cfg, "observation", "kinematics") not in ("kinematics", "rays"):
            raise ValueError(f"road_preview_m adds to the vector observations (kinematics, rays), not to {cfg.observation!r}")
    if getattr(cfg, "reset_hold_s", 0.0) < 0.0:
        raise ValueError(f"reset_hold_s must not be negative, not {cfg.reset_hold_s!r}")
    if getattr(cfg, "policy_hz", 1.0) > getattr(cfg, "physics_hz", 60.0):
        raise ValueError("policy_hz cannot exceed physics_hz")
