"""`physics="fast"`: a dynamic single-track (bicycle) model with saturating tyres.

Why: RL training needs thousands of steps per second; a single-track model captures what
driver-distraction metrics measure (lateral position, yaw, speed) at a fraction of a
rigid-body engine's cost. Below walking pace it blends into the kinematic bicycle model,
where the dynamic one is singular. The step is a compiled kernel (`ego_kernels.body_step`),
shared with the native batch.
"""

from __future__ import annotations

from typing import Any

from .kernels import DYNAMIC_ABOVE, KINEMATIC_BELOW, STOP_SPEED, body_params, body_step_kernel
from .spec import BodyState, VehicleSpec

__all__ = ["DYNAMIC_ABOVE", "KINEMATIC_BELOW", "STOP_SPEED", "FastVehicle"]
G = 9.81


class FastVehicle:
    """Single-track vehicle in the ground plane; height follows `ground_height`."""

    def __init__(self, spec: VehicleSpec, ground_height: Any = None) -> None:
        self.spec = spec
        self.state = BodyState()
        self.ground_height = ground_height  # callable (x, z) -> y, or None for flat
        lf, lr, L = spec.cog_to_front_m, spec.cog_to_rear_m, spec.wheelbase_m
        m = spec.mass_kg
        self._fz_front = m * G * lr / L
        self._fz_rear = m * G * lf / L
        k = spec.cornering_stiffness_per_rad
        self._c_front = k * self._fz_front
        self._c_rear = k * self._fz_rear
        self._max_front = spec.mu * self._fz_front
        self._max_rear = spec.mu * self._fz_rear
        self._max_long = spec.mu * m * G
        self._m, self._lf, self._lr = m, lf, spec.wheelbase_m - lf
        self._wheelbase, self._yaw_inertia = spec.wheelbase_m, spec.yaw_inertia
        self._params = body_params(
            m, lf, spec.wheelbase_m, spec.yaw_inertia, self._max_long, self._c_front, self._c_rear, self._max_front, self._max_rear
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
