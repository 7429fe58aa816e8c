"""The four wheels of the bullet car: suspension rays, spring-damper loads and tyre forces.

Why: this is btRaycastVehicle's model (jME's `VehicleControl`, which OpenDS drives) written
out in Python over pybullet's ray tests, so OpenDS's suspension parameters mean what they
meant there, while the tyres share the fast backend's grip model:
- spring force per wheel = stiffness x compression x chassis mass (Bullet's mass-normalised
  stiffness) on the contact normal, capped at 10000 N (OpenDS's `setMaxSuspensionForce`);
- damping = c x suspension speed x chassis mass, with c = `compression` x 2 sqrt(stiffness)
  while compressing and `damping` x 2 sqrt(stiffness) while extending, as OpenDS's
  `CarModelLoader` feeds jME;
- tyres as `btRaycastVehicle::updateFriction`: per wheel a sideways impulse of 0.2 x the
  contact's sideways speed over its impulse denominator (`resolveSingleBilateral`), a
  forward impulse of the engine force x dt on the driven front wheels (OpenDS's
  `CarControl.accelerate` puts twice its force on each) or rolling friction up to the brake
  impulse on the others (`calcRollingFriction`), both scaled down when they exceed
  load x dt x `frictionSlip` (Bullet's raw impulse limit: 50 means a car that rarely slides).
Assumed geometry (the car's `.properties` asset is not available): wheel radius 0.32 m,
suspension rest length 0.3 m, hard points set so the car rests level with its centre of
gravity at `cog_height_m`. Plain floats: this runs four times per physics step.
"""

from __future__ import annotations

import math
from typing import Any

from ..ego.kernels import side_share_py
from ..ego.spec import VehicleSpec

WHEEL_RADIUS_M = 0.32
SUSPENSION_REST_M = 0.30
MAX_SUSPENSION_FORCE_N = 10000.0
MIN_STIFFNESS = 20.0  # softer springs would sink through the 0.3 m suspension at rest
FORWARD_SLIP_FACTOR = 0.5  # updateFriction's fwdFactor
# btWheelInfo's rollInfluence: the share of the sideways impulse's height above the ground
# that rolls the car. OpenDS's car asset (and its loader's setting) is not available; 0.1 is
# Bullet's own VehicleDemo value, and keeps the car upright in the keyboard swerves of real
# OpenDS drives as OpenDS's did (1.0 rolls it over at 60 km/h).
ROLL_INFLUENCE = 0.1
TWO_PI = 2.0 * math.pi

Vec = tuple[float, float, float]
Rot = tuple[float, float, float, float, float, float, float, float, float]  # row-major 3 x 3


class RaycastWheels:
    """Front-left, front-right, rear-left, rear-right; the front pair steers."""

    def __init__(self, spec: VehicleSpec, gravity_mps2: float) -> None:
        self.spec = spec
        self.gravity = gravity_mps2
        m = spec.mass_kg
        k = max(MIN_STIFFNESS, spec.suspension_stiffness)
        root_k = 2.0 * math.sqrt(k)
        self._k = k
        self._c_compress = max(0.0, spec.suspension_compression) * root_k
        self._c_relax = max(0.0, spec.suspension_damping) * root_k
        self._max_susp = max(MAX_SUSPENSION_FORCE_N, 0.75 * m * gravity_mps2)
        self.ray_len = SUSPENSION_REST_M + WHEEL_RADIUS_M
        lf, lr, wb, h = spec.cog_to_front_m, spec.cog_to_rear_m, spec.wheelbase_m, spec.cog_height_m
        half_track = 0.5 * spec.track_m
        # static compression per wheel: k x m x c = m g share / 2, so the car rests level
        y_f = -h + WHEEL_RADIUS_M + SUSPENSION_REST_M - gravity_mps2 * (lr / wb) / (2.0 * k)
        y_r = -h + WHEEL_RADIUS_M + SUSPENSION_REST_M - gravity_mps2 * (lf / wb) / (2.0 * k)
        # body frame: origin at the centre of gravity, forward -Z, left -X, up +Y
        self._hardpoints = ((-half_track, y_f, -lf), (half_track, y_f, -lf), (-half_track, y_r, lr), (half_track, y_r, lr))
        self._steered = (True, True, False, False)
        L, W, H = spec.length_m, spec.width_m, spec.height_m  # the chassis box's inertia (bullet.vehicle)
        self._inv_inertia = (12.0 / (m * (H * H + L * L)), 1.0 / spec.yaw_inertia, 12.0 / (m * (H * H + W * W)))
        self.suspension_m = [SUSPENSION_REST_M] * 4
        self.load_n = [0.0] * 4
        self.spin_rad = [0.0] * 4

    def _denominator(self, rx: float, ry: float, rz: float, nx: float, ny: float, nz: float, rot: Rot, inv_m: float) -> float:
        """Bullet's computeImpulseDenominator: 1/m + (r x n) . I^-1 (r x n), I in the body frame."""
        cx, cy, cz = ry * nz - rz * ny, rz * nx - rx * nz, rx * ny - ry * nx
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
        bx = r00 * cx + r10 * cy + r20 * cz  # R^T (r x n)
        by = r01 * cx + r11 * cy + r21 * cz
        bz = r02 * cx + r12 * cy + r22 * cz
        ii0, ii1, ii2 = self._inv_inertia
        return inv_m + bx * bx * ii0 + by * by * ii1 + bz * bz * ii2

    def reset(self) -> None:
        for i in range(4):
            self.suspension_m[i], self.load_n[i], self.spin_rad[i] = SUSPENSION_REST_M, 0.0, 0.0

    def get_state(self) -> tuple[tuple[float, ...], ...]:
        return (tuple(self.suspension_m), tuple(self.load_n), tuple(self.spin_rad))

    def set_state(self, state: tuple[tuple[float, ...], ...]) -> None:
        self.suspension_m[:], self.load_n[:], self.spin_rad[:] = (list(v) for v in state)

    def rays(self, pos: Vec, rot: Rot) -> tuple[list[Vec], list[Vec]]:
        """Suspension rays (from the hard points along the body's down axis) for `rayTestBatch`."""
        px, py, pz = pos
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
        dx, dy, dz = -r01, -r11, -r21
        ray = self.ray_len
        froms: list[Vec] = []
        tos: list[Vec] = []
        for hx, hy, hz in self._hardpoints:
            ax = px + r00 * hx + r01 * hy + r02 * hz
            ay = py + r10 * hx + r11 * hy + r12 * hz
            az = pz + r20 * hx + r21 * hy + r22 * hz
            froms.append((ax, ay, az))
            tos.append((ax + dx * ray, ay + dy * ray, az + dz * ray))
        return froms, tos

    def forces(
        self, hits: Any, pos: Vec, rot: Rot, lin: Vec, ang: Vec, steer_rad: float, drive_force_n: float, brake_force_n: float, dt_s: float
    ) -> tuple[Vec, Vec]:
        """Total force and torque (about the centre of gravity, world frame) the wheels put on the chassis."""
        spec = self.spec
        m = spec.mass_kg
        px, py, pz = pos
        lx, ly, lz = lin
        wx, wy, wz = ang
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rot
        dx, dy, dz = -r01, -r11, -r21  # the suspension's down axis
        ray = self.ray_len
        # pass 1: suspension forces (btRaycastVehicle::updateSuspension)
        k, c_in, c_out, cap = self._k, self._c_compress, self._c_relax, self._max_susp
        loads = self.load_n
        contacts: list[Any] = [None, None, None, None]
        total_load = 0.0
        for i, hit in enumerate(hits):
            if hit[0] < 0:
                loads[i] = 0.0
                self.suspension_m[i] = SUSPENSION_REST_M
                continue
            length = hit[2] * ray - WHEEL_RADIUS_M
            if length < 0.0:
                length = 0.0
            cx, cy, cz = hit[3]
            nx, ny, nz = hit[4]
            rx, ry, rz = cx - px, cy - py, cz - pz
            vx = lx + wy * rz - wz * ry
            vy = ly + wz * rx - wx * rz
            vz = lz + wx * ry - wy * rx
            denom = nx * dx + ny * dy + nz * dz
            if denom >= -0.1:
                inv, rel_v = 10.0, 0.0
            else:
                inv = -1.0 / denom
                rel_v = (nx * vx + ny * vy + nz * vz) * inv
            force = (k * (SUSPENSION_REST_M - length) * inv - (c_in if rel_v < 0.0 else c_out) * rel_v) * m
            force = 0.0 if force < 0.0 else cap if force > cap else force
            loads[i] = force
            self.suspension_m[i] = length
            total_load += force
            contacts[i] = (rx, ry, rz, nx, ny, nz, vx, vy, vz)
        # pass 2: btRaycastVehicle::updateFriction, impulses per wheel from this step's velocities
        fx_t = fy_t = fz_t = tx_t = ty_t = tz_t = 0.0
        on_ground = sum(1 for ct in contacts if ct is not None)
        if on_ground:
            dt = dt_s
            inv_m = 1.0 / m
            slip = spec.friction_slip
            front_force = 0.5 * drive_force_n  # CarControl.accelerate: twice the engine force per front wheel
            brake_imp = 0.25 * brake_force_n * dt
            side = side_share_py(dt)  # resolveSingleBilateral's 0.2 per OpenDS tick
            s_d, c_d = math.sin(steer_rad), math.cos(steer_rad)
            for i in range(4):
                ct = contacts[i]
                if ct is None:
                    continue
                rx, ry, rz, nx, ny, nz, vx, vy, vz = ct
                if self._steered[i]:
                    hx, hy, hz = -r00 * s_d - r02 * c_d, -r10 * s_d - r12 * c_d, -r20 * s_d - r22 * c_d
                else:
                    hx, hy, hz = -r02, -r12, -r22
                dot = hx * nx + hy * ny + hz * nz
                hx, hy, hz = hx - nx * dot, hy - ny * dot, hz - nz * dot
                norm = math.sqrt(hx * hx + hy * hy + hz * hz)
                if norm <= 1e-6:
                    fx_t += nx * loads[i]
                    fy_t += ny * loads[i]
                    fz_t += nz * loads[i]
                    continue
                hx, hy, hz = hx / norm, hy / norm, hz / norm
                sx, sy, sz = ny * hz - nz * hy, nz * hx - nx * hz, nx * hy - ny * hx  # the axle (left)
                # resolveSingleBilateral: 0.2 x the sideways speed over the contact's impulse denominator
                j_side = -side * (sx * vx + sy * vy + sz * vz) / self._denominator(rx, ry, rz, sx, sy, sz, rot, inv_m)
                if self._steered[i] and front_force != 0.0:
                    j_fwd = front_force * dt
                else:
                    # calcRollingFriction: stop the contact's forward motion, at most the brake impulse
                    j_fwd = -(hx * vx + hy * vy + hz * vz) / self._denominator(rx, ry, rz, hx, hy, hz, rot, inv_m) / on_ground
                    j_fwd = brake_imp if j_fwd > brake_imp else -brake_imp if j_fwd < -brake_imp else j_fwd
                max_imp = loads[i] * dt * slip
                xf = j_fwd * FORWARD_SLIP_FACTOR
                sq = xf * xf + j_side * j_side
                if sq > max_imp * max_imp:
                    k_slide = max_imp / math.sqrt(sq)
                    j_fwd *= k_slide
                    j_side *= k_slide
                f_fwd, f_side = j_fwd / dt, j_side / dt
                v_long = hx * vx + hy * vy + hz * vz
                self.spin_rad[i] = (self.spin_rad[i] + v_long / WHEEL_RADIUS_M * dt) % TWO_PI
                load = loads[i]
                gx = nx * load + hx * f_fwd
                gy = ny * load + hy * f_fwd
                gz = nz * load + hz * f_fwd
                ex, ey, ez = sx * f_side, sy * f_side, sz * f_side
                fx_t += gx + ex
                fy_t += gy + ey
                fz_t += gz + ez
                tx_t += ry * gz - rz * gy
                ty_t += rz * gx - rx * gz
                tz_t += rx * gy - ry * gx
                # the sideways impulse acts with its lever arm along the body's up axis scaled by rollInfluence
                up = (rx * r01 + ry * r11 + rz * r21) * (1.0 - ROLL_INFLUENCE)
                qx, qy, qz = rx - r01 * up, ry - r11 * up, rz - r21 * up
                tx_t += qy * ez - qz * ey
                ty_t += qz * ex - qx * ez
                tz_t += qx * ey - qy * ex
        return (fx_t, fy_t, fz_t), (tx_t, ty_t, tz_t)
