"""A driver's decision for one policy step, and its translation into an env's action.

Why: driver models decide in driver terms (steer, pedal, press the reaction button,
indicate) whatever the env's action type is; one function turns that into the
`continuous`, `continuous_buttons` or `discrete` action the env expects.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

SPEED_DEADBAND_MPS = 5.0 / 3.6  # the discrete type's speed steps are 10 km/h


@dataclass(frozen=True)
class Intent:
    steering: float = 0.0  # -1..1, + left
    pedal: float = 0.0  # -1 brake .. +1 throttle
    reaction: bool = False  # hold the reaction button (a press is its rising edge)
    indicator: str = "off"  # off | left | right
    target_lateral_m: float = 0.0  # for meta-actions: where across the road to be
    target_speed_mps: float = 0.0


def to_action(env: Any, intent: Intent) -> Any:
    """The env's action for `intent` (env may be wrapped)."""
    base = env.unwrapped
    act_type = base.act_type
    steer = _clip(float(intent.steering))
    pedal = _clip(float(intent.pedal))
    if act_type.name == "continuous":
        return np.array([steer, pedal], dtype=np.float32)
    if act_type.name == "continuous_buttons":
        left = intent.indicator == "left"
        right = intent.indicator == "right"
        buttons = [intent.reaction, False, left, right]
        return np.array([steer, pedal] + [1.0 if b else -1.0 for b in buttons], dtype=np.float32)
    if act_type.name == "discrete":
        return _meta_action(base, act_type, intent)
    raise ValueError(f"driver models do not know the action type {act_type.name!r}")


def _clip(v: float) -> float:
    """`np.clip(v, -1, 1)` of one float (the same value, NaN kept), without numpy's per-call cost."""
    return v if v != v else min(1.0, max(-1.0, v))


def _meta_action(base: Any, act_type: Any, intent: Intent) -> int:
    lats = base.guide.lane_laterals_m
    want = min(range(len(lats)), key=lambda i: abs(lats[i] - intent.target_lateral_m))
    have = act_type.target_lane
    if lats[want] > lats[have] + 1e-6:
        return act_type.LEFT
    if lats[want] < lats[have] - 1e-6:
        return act_type.RIGHT
    if intent.target_speed_mps > act_type.target_speed + SPEED_DEADBAND_MPS:
        return act_type.FASTER
    if intent.target_speed_mps < act_type.target_speed - SPEED_DEADBAND_MPS:
        return act_type.SLOWER
    return act_type.KEEP
