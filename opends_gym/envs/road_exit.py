"""What happens when the car leaves the road: `on_road_exit` and the reset to the last lane
position.

Why: an episode that ends when the car leaves the road measures survival, not the task: a
distracted driver who drifts off early is never shown the later stimuli, so its misses and
reaction times are missing, not bad (issue: exposure, not survival). OpenDS never ends a
drive on leaving the road; the participant steers back or the experimenter resets the car
(`Car.setToResetPosition`, bound to the RESET_CAR key `KEY_R` by `SimulatorActionListener`),
which places it at a pose at rest (`Car.setPosition` zeroes the velocity).

Modes (`EnvConfig.on_road_exit`):

* `terminate` (default, for RL): the episode ends on leaving the road, as before.
* `recover` (the study runner's default): the car is put back at rest at the point where
  it was last on a lane, in the centre of the lane it last drove in for 1 s (not one it
  only crossed on its way off the road), facing along the road, and held still (brake on)
  for `reset_hold_s` simulated seconds. OpenDS has no hold (the
  car may drive off at once after `Car.setPosition`); ours defaults to 2 s so that leaving
  the road always costs time and a policy cannot use resets as a shortcut.
* `continue`: nothing happens; the car may drive on off the road.

The same reset is `OpenDSEnv.reset_position()` (human sessions: key, CAN, settings server).
Traffic is not moved: in the Three-Vehicle Platoon the follower car may run into the car
held after a reset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..sim.controls import DriverControls
from ..task.model_task import Pose
from ..task.values import Rotation, euler_deg_to_quat

ROAD_EXIT_MODES = ("terminate", "recover", "continue")
DEFAULT_RESET_HOLD_S = 2.0  # ours, not OpenDS's (see the module docstring)
RESET_SOURCE = "last_lane_position"  # the `source` of the World's `reset` event for this reset


@dataclass
class LanePose:
    """Where the car was last in a lane: its position, the lane's offset and the road heading."""

    x: float
    y: float
    z: float
    lane_offset_m: float
    heading_rad: float

    def lane_centre_pose(self) -> Pose:
        """The pose in the lane's centre at that point, facing along the road. The road's
        left at heading h is (-cos h, sin h) in OpenDS's X/Z (yaw 0 faces -Z)."""
        h = self.heading_rad
        x = self.x + self.lane_offset_m * math.cos(h)
        z = self.z - self.lane_offset_m * math.sin(h)
        return Pose((x, self.y, z), Rotation(euler_deg_to_quat(0.0, math.degrees(h), 0.0)))


def check_mode(mode: str) -> str:
    if mode not in ROAD_EXIT_MODES:
        raise ValueError(f"on_road_exit must be one of {', '.join(ROAD_EXIT_MODES)}, not {mode!r}")
    return mode


def held(c: DriverControls) -> DriverControls:
    """The controls while the car is held after a reset: full brake, no gas, wheel straight
    (one-shot inputs such as keys and buttons still pass: the driver may answer stimuli)."""
    d = DriverControls(**c.__dict__)
    d.steering, d.accelerator, d.brake = 0.0, 0.0, 1.0
    return d
