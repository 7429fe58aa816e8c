"""`physics="fast"`: OpenDS's Bullet raycast vehicle in the ground plane.

Why: RL training needs thousands of steps per second, and the car must still drive like
OpenDS's, which is jME's `VehicleControl` (Bullet's `btRaycastVehicle`): a rigid chassis
held by four wheel contacts whose sideways impulses remove a fixed share of the sliding
each step, with engine impulses on the front wheels and brake-capped rolling friction on
the others. This backend keeps that tyre model and drops what a flat road does not need
(suspension travel, pitch and roll). The step is a compiled kernel
(`ego.kernels.body_step`), shared with the native batch.
"""

from __future__ import annotations

from typing import Any

from .kernels import body_params, body_step_kernel
from .spec import BodyState, VehicleSpec

__all__ = ["FastVehicle"]
G = 9.81


class FastVehicle:
    """Planar raycast vehicle; height follows `ground_height`."""

    def __init__(self, spec: VehicleSpec, ground_height: Any = None, ground_pitch: Any = None) -> None:
        self.spec = spec
        self.state = BodyState()
        self.ground_height = ground_height  # callable (x, z) -> y, or None for flat
        self.ground_pitch = ground_pitch  # callable (x, z, yaw) -> the road's slope ahead (rad, uphill positive), or None for flat
        m, w, h = spec.mass_kg, spec.width_m, spec.height_m
        roll_inertia = m * (h * h + w * w) / 12.0  # the bullet chassis box's (bullet.vehicle)
        self._params = body_params(
            m,
            spec.cog_to_front_m,
            spec.wheelbase_m,
            spec.yaw_inertia,
            0.5 * spec.track_m,
            spec.friction_slip,
            G,
            spec.cog_height_m,
            roll_inertia,
        )

    def reset(self, x: float, y: float, z: float, yaw: float, speed_mps: float) -> None:
        self.state = BodyState(x=x, y=y, z=z, yaw=yaw, u=speed_mps)

    def step(self, dt_s: float, steer_rad: float, drive_force_n: float, brake_force_n: float, side_force_n: float = 0.0) -> None:
        s = self.state
        s.steer_rad = steer_rad
        s.x, s.z, s.yaw, s.u, s.v, s.r = body_step_kernel(
            self._params, s.x, s.z, s.yaw, s.u, s.v, s.r, dt_s, steer_rad, drive_force_n, brake_force_n, side_force_n
        )
        if self.ground_height is not None:
            s.y = self.ground_height(s.x, s.z)

    def stop_at_contact(self, x: float, z: float) -> None:
        """Fully inelastic contact: back to the last free position, at rest."""
        s = self.state
        s.x, s.z = x, z
        s.u = s.v = s.r = 0.0

    def get_state(self) -> dict[str, Any]:
        s = self.state
        return {"pose": (s.x, s.y, s.z, s.yaw, s.pitch, s.roll), "vel": (s.u, s.v, s.r), "steer": s.steer_rad}

    def set_state(self, state: dict[str, Any]) -> None:
        s = self.state
        s.x, s.y, s.z, s.yaw, s.pitch, s.roll = state["pose"]
        s.u, s.v, s.r = state["vel"]
        s.steer_rad = state["steer"]

    def close(self) -> None:
        return None
