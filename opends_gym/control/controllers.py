"""Low-level controllers: steer onto a lateral target line, hold a speed.

Why: the discrete meta-actions of the envs and the rule-based driver both need a
competent lane keeper and speed holder. The lateral law is Stanley's (Hoffmann et al.
2007): front-wheel angle = -(heading error + atan(k * lateral error / (v + v0))).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..sim.ego.spec import MAX_WHEEL_ANGLE_RAD
from ..sim.guide import wrap_angle


@dataclass(frozen=True)
class StanleyGains:
    k_lateral: float = 1.2
    v0_mps: float = 2.0
    k_heading: float = 1.0
    k_yaw_damping: float = 0.08  # per rad/s of yaw rate, against oscillation at speed


def stanley_steering(
    yaw: float,
    road_heading: float,
    lateral_m: float,
    target_lateral_m: float,
    speed_mps: float,
    yaw_rate: float = 0.0,
    gains: StanleyGains = StanleyGains(),
) -> float:
    """Steering input (-1..1, + left) that brings the car onto `target_lateral_m`."""
    heading_err = wrap_angle(yaw - road_heading)
    lat_err = lateral_m - target_lateral_m  # + : left of the target
    angle = (
        -(gains.k_heading * heading_err + math.atan2(gains.k_lateral * lat_err, abs(speed_mps) + gains.v0_mps))
        - gains.k_yaw_damping * yaw_rate
    )
    return max(-1.0, min(1.0, angle / MAX_WHEEL_ANGLE_RAD))


def speed_pedal(speed_mps: float, target_mps: float, gain: float = 0.4) -> float:
    """Pedal (-1 brake .. +1 throttle) proportional to the speed error."""
    return max(-1.0, min(1.0, gain * (target_mps - speed_mps)))


def pure_pursuit_steering(
    yaw: float, road_heading: float, lateral_m: float, target_lateral_ahead_m: float, lookahead_m: float, wheelbase_m: float = 2.7
) -> float:
    """Steering input (-1..1, + left) towards the path point `lookahead_m` ahead.

    Pure pursuit (Coulter 1992): the arc through the rear axle and the look-ahead point;
    `target_lateral_ahead_m` is the path's lateral position at that distance along the road.
    """
    heading = wrap_angle(yaw - road_heading)
    dy = target_lateral_ahead_m - lateral_m
    ahead = lookahead_m * math.cos(heading) + dy * math.sin(heading)
    left = -lookahead_m * math.sin(heading) + dy * math.cos(heading)
    alpha = math.atan2(left, ahead)
    delta = math.atan2(2.0 * wheelbase_m * math.sin(alpha), math.hypot(ahead, left))
    return max(-1.0, min(1.0, delta / MAX_WHEEL_ANGLE_RAD))


def pure_pursuit(ahead_m: float, left_m: float, wheelbase_m: float) -> float:
    """Steering input (-1..1, + left) onto the arc through a target point (ahead, left) in
    the car's frame (Coulter 1992): curvature 2 * left / distance^2, wheel angle
    atan(wheelbase * curvature)."""
    d2 = ahead_m * ahead_m + left_m * left_m
    if d2 < 1e-6:
        return 0.0
    delta = math.atan(wheelbase_m * 2.0 * left_m / d2)
    return max(-1.0, min(1.0, delta / MAX_WHEEL_ANGLE_RAD))
