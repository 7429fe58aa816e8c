"""What the ego car can see of traffic: the lead vehicle, gaps and closing speeds.

Why: headway, TTC, adaptive cruise control, the rule driver and observations all ask
"who is ahead of me in my lane". One compiled loop over the traffic arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .traffic.queries import nearest_ahead
from .world import World


@dataclass(frozen=True)
class Lead:
    index: int
    gap_m: float  # bumper to bumper
    speed_mps: float  # along the ego's heading
    length_m: float
    brake_light: bool


def lead_vehicle(world: World, half_width_m: float = 1.5, max_range_m: float = 200.0) -> Lead | None:
    """Nearest enabled traffic object ahead whose centre is within `half_width_m` laterally."""
    traffic = world.traffic
    if traffic is None or len(traffic.ids) == 0:
        return None
    s = world.ego.state
    fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
    lx, lz = -math.cos(s.yaw), math.sin(s.yaw)
    j, ahead = nearest_ahead(traffic.positions, traffic.enabled, traffic._all_rows, s.x, s.z, fx, fz, lx, lz, half_width_m, max_range_m)
    if j < 0:
        return None
    half_len = float(traffic.half_extents[j, 1])
    gap = float(ahead) - half_len - 0.5 * world.ego.spec.length_m
    vyaw = float(traffic.yaw[j])
    v_along = float(traffic.speed[j]) * (-math.sin(vyaw) * fx - math.cos(vyaw) * fz)
    return Lead(j, gap, v_along, 2.0 * half_len, bool(traffic.brake_light[j]))
