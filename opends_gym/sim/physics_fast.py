"""`physics="fast"`: a dynamic single-track (bicycle) model with saturating tyres.

Why: RL training needs thousands of steps per second; a single-track model captures what
driver-distraction metrics measure (lateral position, yaw, speed) at a fraction of a
rigid-body engine's cost. Below walking pace it blends into the kinematic bicycle model,
where the dynamic one is singular. Plain floats on purpose (one car per call).
"""

from __future__ import annotations

import math
from typing import Any

from .vehicle import BodyState, VehicleSpec

KINEMATIC_BELOW = 1.0  # m/s: purely kinematic below this forward speed
DYNAMIC_ABOVE = 3.0  # m/s: purely dynamic above this
STOP_SPEED = 0.05  # m/s: at rest below this when no drive force
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

    def reset(self, x: float, y: float, z: float, yaw: float, speed_mps: float) -> None:
        self.state = BodyState(x=x, y=y, z=z, yaw=yaw, u=speed_mps)

    def step(self, dt_s: float, steer_rad: float, drive_force_n: float, brake_force_n: float, side_force_n: float = 0.0) -> None:
        s = self.state
        m, lf, lr = self._m, self._lf, self._lr
        u, v, r = s.u, s.v, s.r
        s.steer_rad = steer_rad
        # longitudinal force: drive minus brakes (brakes oppose motion, never reverse it)
        fx = drive_force_n
        if fx > self._max_long:
            fx = self._max_long
        elif fx < -self._max_long:
            fx = -self._max_long
        brake = brake_force_n if brake_force_n < self._max_long else self._max_long
        if u > 0.0:
            fx -= brake
        elif u < 0.0:
            fx += brake
        elif -brake <= fx <= brake:
            fx = 0.0
        else:
            fx -= math.copysign(brake, fx)
        au = abs(u)
        if au < DYNAMIC_ABOVE:
            w_dyn = 0.0 if au <= KINEMATIC_BELOW else (au - KINEMATIC_BELOW) / (DYNAMIC_ABOVE - KINEMATIC_BELOW)
        else:
            w_dyn = 1.0
        u_new = u + fx / m * dt_s
        if w_dyn > 0.0:
            # dynamic bicycle model with tanh-saturated tyre forces
            cos_d = math.cos(steer_rad)
            sin_d = math.sin(steer_rad)
            uu = u if au > 0.5 else math.copysign(0.5, u if u != 0.0 else 1.0)
            # slip angles; the force opposes the tyre's sideways slip, so reversing flips them
            sign = 1.0 if uu > 0.0 else -1.0
            alpha_f = sign * (steer_rad - math.atan((v + lf * r) / uu))
            alpha_r = -sign * math.atan((v - lr * r) / uu)
            fyf = self._max_front * math.tanh(self._c_front * alpha_f / self._max_front)
            fyr = self._max_rear * math.tanh(self._c_rear * alpha_r / self._max_rear)
            dv_dyn = (fyf * cos_d + fyr + side_force_n) / m - u * r
            dr_dyn = (lf * fyf * cos_d - lr * fyr) / self._yaw_inertia
            u_new += (-fyf * sin_d / m + v * r) * dt_s
            v_dyn = v + dv_dyn * dt_s
            r_dyn = r + dr_dyn * dt_s
        else:
            v_dyn = r_dyn = 0.0
        if w_dyn < 1.0:
            # kinematic bicycle model: no tyre slip at walking pace
            tan_d = math.tan(steer_rad)
            beta = math.atan(lr * tan_d / self._wheelbase)
            r_kin = u_new * math.cos(beta) * tan_d / self._wheelbase
            v_kin = u_new * math.tan(beta)
            v_new = w_dyn * v_dyn + (1.0 - w_dyn) * v_kin
            r_new = w_dyn * r_dyn + (1.0 - w_dyn) * r_kin
        else:
            v_new, r_new = v_dyn, r_dyn
        # brakes stop the car; they do not push it backwards
        if (u > 0.0 > u_new or u < 0.0 < u_new) and abs(drive_force_n) <= brake:
            u_new = 0.0
        if abs(u_new) < STOP_SPEED and abs(drive_force_n) <= brake + 1e-9:
            u_new = v_new = r_new = 0.0
        s.u, s.v, s.r = u_new, v_new, r_new
        s.yaw += r_new * dt_s
        sy, cy = math.sin(s.yaw), math.cos(s.yaw)
        # forward (-sin, -cos), left (-cos, +sin) in (x, z)
        s.x += (-u_new * sy - v_new * cy) * dt_s
        s.z += (-u_new * cy + v_new * sy) * dt_s
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
