"""The four wheels of the bullet car: suspension rays, spring-damper loads and tyre forces.

Why: this is btRaycastVehicle's model (jME's `VehicleControl`, which OpenDS drives) written
out in Python over pybullet's ray tests, so OpenDS's suspension parameters mean what they
meant there, while the tyres share the fast backend's grip model:
- spring force per wheel = stiffness x compression x chassis mass (Bullet's mass-normalised
  stiffness) on the contact normal, capped at 10000 N (OpenDS's `setMaxSuspensionForce`);
- damping = c x suspension speed x chassis mass, with c = `compression` x 2 sqrt(stiffness)
  while compressing and `damping` x 2 sqrt(stiffness) while extending, as OpenDS's
  `CarModelLoader` feeds jME;
- tyres: Bullet's `frictionSlip` is a raw impulse limit (50 would mean mu = 50, a car that
  never slides), so the friction circle is `VehicleSpec.mu` x load (frictionSlip / 50), with
  the fast backend's saturating cornering stiffness per unit load above walking pace and
  Bullet's no-sideways-slip constraint below it (so a parked car holds on a slope);
- drive force on all four wheels (OpenDS accelerates both axles), brakes against each
  wheel's motion and never past a stop; both split by wheel load.
Assumed geometry (the car's `.properties` asset is not available): wheel radius 0.32 m,
suspension rest length 0.3 m, hard points set so the car rests level with its centre of
gravity at `cog_height_m`. Plain floats: this runs four times per physics step.
"""

from __future__ import annotations

import math
from typing import Any

from ..ego.spec import VehicleSpec

WHEEL_RADIUS_M = 0.32
SUSPENSION_REST_M = 0.30
MAX_SUSPENSION_FORCE_N = 10000.0
MIN_STIFFNESS = 20.0  # softer springs would sink through the 0.3 m suspension at rest
KINEMATIC_BELOW = 1.0  # m/s: below this the tyres hold sideways like Bullet's constraint (as physics_fast)
DYNAMIC_ABOVE = 3.0  # m/s: above this the slip-angle tyre model alone
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
        self.suspension_m = [SUSPENSION_REST_M] * 4
        self.load_n = [0.0] * 4
        self.spin_rad = [0.0] * 4

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
        # pass 2: tyre forces, friction circle mu x load, then one force and torque at the CoG
        fx_t = fy_t = fz_t = tx_t = ty_t = tz_t = 0.0
        if total_load > 0.0:
            dt = dt_s
            g = self.gravity
            mu = spec.mu
            mu = mu if mu > 1e-3 else 1e-3
            corner = spec.cornering_stiffness_per_rad / mu
            s_d, c_d = math.sin(steer_rad), math.cos(steer_rad)
            for i in range(4):
                ct = contacts[i]
                if ct is None:
                    continue
                rx, ry, rz, nx, ny, nz, vx, vy, vz = ct
                load = loads[i]
                if self._steered[i]:
                    hx, hy, hz = -r00 * s_d - r02 * c_d, -r10 * s_d - r12 * c_d, -r20 * s_d - r22 * c_d
                else:
                    hx, hy, hz = -r02, -r12, -r22
                dot = hx * nx + hy * ny + hz * nz
                hx, hy, hz = hx - nx * dot, hy - ny * dot, hz - nz * dot
                norm = math.sqrt(hx * hx + hy * hy + hz * hz)
                fx_w = fy_w = 0.0
                if norm > 1e-6:
                    hx, hy, hz = hx / norm, hy / norm, hz / norm
                    sx, sy, sz = ny * hz - nz * hy, nz * hx - nx * hz, nx * hy - ny * hx  # left
                    v_long = hx * vx + hy * vy + hz * vz
                    v_lat = sx * vx + sy * vy + sz * vz
                    share = load / total_load
                    m_w = m * share
                    drive = drive_force_n * share
                    brake = brake_force_n * share
                    # brakes: up to `brake` against the motion (and gravity's pull), never past a stop
                    b = -m_w * (v_long / dt - g * hy) - drive
                    fx_w = drive + (brake if b > brake else -brake if b < -brake else b)
                    f_max = mu * load
                    speed = v_long if v_long >= 0.0 else -v_long
                    # sideways: the force that stops sliding this step (a parked car holds on a slope)
                    hold = -m_w * (v_lat / dt - g * sy)
                    if speed > KINEMATIC_BELOW:
                        # slip-angle tyre, never pushing past zero slip
                        grip = abs(f_max * math.tanh(corner * math.atan2(v_lat, speed)))
                        stop = m_w * abs(v_lat) / dt
                        if grip > stop:
                            grip = stop
                        fy_w = -grip if v_lat > 0.0 else grip
                        if speed < DYNAMIC_ABOVE:
                            blend = (speed - KINEMATIC_BELOW) / (DYNAMIC_ABOVE - KINEMATIC_BELOW)
                            fy_w = blend * fy_w + (1.0 - blend) * hold
                    else:
                        fy_w = hold
                    total = math.sqrt(fx_w * fx_w + fy_w * fy_w)
                    if total > f_max:
                        fx_w *= f_max / total
                        fy_w *= f_max / total
                    self.spin_rad[i] = (self.spin_rad[i] + v_long / WHEEL_RADIUS_M * dt) % TWO_PI
                else:
                    sx = sy = sz = 0.0
                gx = nx * load + hx * fx_w + sx * fy_w
                gy = ny * load + hy * fx_w + sy * fy_w
                gz = nz * load + hz * fx_w + sz * fy_w
                fx_t += gx
                fy_t += gy
                fz_t += gz
                tx_t += ry * gz - rz * gy
                ty_t += rz * gx - rx * gz
                tz_t += rx * gy - ry * gx
        return (fx_t, fy_t, fz_t), (tx_t, ty_t, tz_t)
