"""What happens when the car hits something: `on_collision` and the reset behind what it hit.

Why: an episode that ends at the first rear-end collision measures survival, not the task:
a driver who never brakes in the brake test is never shown the later brake events, so its
misses are missing, not counted (issue: exposure, not survival). OpenDS never ends a drive
on a collision: its physics (jBullet) stops the car against what it hit and the drive goes
on; the participant drives off again or the experimenter resets the car
(`Car.setToResetPosition`, the RESET_CAR key of `SimulatorActionListener`), which places it
at rest (`Car.setPosition` zeroes the velocity). OpenDS's own traffic avoids the driving
car (`TrafficCar.updateSpeed` stops for obstacles in the way, the driving car included).

Modes (`EnvConfig.on_collision`; unset, it follows the older `terminate_on_collision`:
True is `terminate`, False is `continue`):

* `terminate` (the default, for RL): the episode ends on the collision.
* `recover` (the study runner's default): at the start of the next physics step the car is
  put back at rest in the centre of its lane, moved back along the road until its box is
  clear of every car and obstacle, then `COLLISION_GAP_M` further, facing along the road,
  and held still for `reset_hold_s` (the same time penalty as a reset after leaving the
  road). Counted in `collisions`, `resets` and `collision_resets`; a World `reset` event
  with source `collision` marks it. Traffic is not moved: the lead car drives on, and in the
  Three-Vehicle Platoon the follower car may run into the held car (a further collision,
  handled the same way).
  In the platoon and brake tests, passing the lead car (which voids OpenDS's test and
  ends the episode under `terminate`) is recovered the same way: the car is put back
  behind the lead car, in its lane (a `reset` event with source `passed_lead`, counted in
  `resets`).
* `continue`: nothing happens; the car drives on through traffic (our traffic has no
  contact physics; obstacles stop it, `WorldConfig.collision_stops_car`).
"""

from __future__ import annotations

import math

import numpy as np

from ..sim.geometry2d import Obb
from ..sim.guide import RoadGuide
from ..sim.world import TRAFFIC_REACH_Y_M, World
from ..task.model_task import Pose
from .road_exit import LanePose

COLLISION_MODES = ("terminate", "recover", "continue")
COLLISION_SOURCE = "collision"  # the `source` of the World's `reset` event for this reset
PASSED_LEAD_SOURCE = "passed_lead"  # the platoon/brake tests' reset after passing the lead car
# Ours, not OpenDS's (it has no automatic reset): a short bumper gap once clear of what was hit.
# A larger one would move the car into a platoon's follower (5-15 m behind).
COLLISION_GAP_M = 2.0
BACK_OFF_STEP_M = 0.25  # search step backwards along the road for a clear position
BACK_OFF_MAX_M = 60.0  # give up searching beyond this (the car is put back at the last clear step tried)


def collision_mode(on_collision: str | None, terminate_on_collision: bool) -> str:
    """The effective mode: `on_collision`, or the one `terminate_on_collision` implies."""
    if on_collision is None:
        return "terminate" if terminate_on_collision else "continue"
    if on_collision not in COLLISION_MODES:
        raise ValueError(f"on_collision must be one of {', '.join(COLLISION_MODES)}, not {on_collision!r}")
    return on_collision


def _box_at(world: World, pose: Pose) -> Obb:
    """The ego's box at `pose` (as `World.ego_obb`: the box is centred on the car)."""
    spec = world.ego.spec
    shift = 0.5 * spec.wheelbase_m - spec.cog_to_front_m
    x, _, z = pose.position_m
    yaw = pose.yaw_rad
    return Obb(x - shift * math.sin(yaw), z - shift * math.cos(yaw), yaw, 0.5 * spec.width_m, 0.5 * spec.length_m)


def _clear(world: World, pose: Pose) -> bool:
    """No traffic object (within reach in height) and no obstacle overlaps the ego at `pose`."""
    box = _box_at(world, pose)
    y = pose.position_m[1]
    traffic = world.traffic
    if traffic is not None:
        for oid in traffic.colliding_with(box):
            if abs(float(traffic.positions[traffic.ids.index(oid), 1]) - y) < TRAFFIC_REACH_Y_M:
                return False
    _, obstacles, _ = world.objects.overlapping_with_room(box, y - 0.5, y + world.ego.spec.height_m)
    return not obstacles


def collision_reset_pose(world: World, guide: RoadGuide, lane: int, behind_xz: tuple[float, float] | None = None) -> Pose:
    """Where the car is put back after a collision: in the centre of `lane` (-1: where it
    is across the road), backed along the road from the ego (or from `behind_xz`, e.g. the
    lead car it passed) until clear, then `COLLISION_GAP_M` more."""
    s = world.ego.state
    x, z = behind_xz if behind_xz is not None else (s.x, s.z)
    pose: Pose | None = None
    for back in np.arange(0.0, BACK_OFF_MAX_M + 1e-9, BACK_OFF_STEP_M):
        pose = _lane_pose_back(guide, x, s.y, z, lane, float(back))
        if _clear(world, pose):
            return _lane_pose_back(guide, x, s.y, z, lane, float(back) + COLLISION_GAP_M)
    assert pose is not None
    return pose


def _lane_pose_back(guide: RoadGuide, x: float, y: float, z: float, lane: int, back_m: float) -> Pose:
    """The lane-centre pose `back_m` behind (x, z) along the road, facing along it."""
    p = guide.locate(x, z)
    h = guide.heading_at(p.s_m)
    # facing along the road at heading h is (-sin h, -cos h) in OpenDS's X/Z (yaw 0 faces -Z)
    bx, bz = x + back_m * math.sin(h), z + back_m * math.cos(h)
    q = guide.locate(bx, bz)
    laterals = guide.lane_laterals_m
    offset = q.lateral_m - laterals[lane] if 0 <= lane < len(laterals) else 0.0
    return LanePose(bx, y, bz, offset, guide.heading_at(q.s_m)).lane_centre_pose()
