"""The ego cars of a native batch: controls -> cruise/minSpeed -> powertrain -> single-track body.

Why: this is `sim.ego.EgoCar.step` + `sim.powertrain.Powertrain.step` +
`sim.physics_fast.FastVehicle.step` for N cars at once, one numpy array per state
variable. Every expression keeps the single env's operand order, so the results are the
same floats (see `libm` for the transcendental functions); branches become masks. Only
what the three batched tasks use is modelled: automatic gearbox, cruise control without
ACC, the engine's minSpeed, no crosswind, clutch, hand brake, slope or manual shifting
(`EgoParams.from_world` refuses a car that needs more).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..sim import powertrain as ptm
from ..sim.ego import CRUISE_GAIN, CRUISE_INTEGRAL_BAND_MPS, CRUISE_INTEGRAL_MAX, CRUISE_KI
from ..sim.physics_fast import DYNAMIC_ABOVE, KINEMATIC_BELOW, STOP_SPEED
from ..sim.vehicle import MAX_WHEEL_ANGLE_RAD
from . import libm


@dataclass(frozen=True)
class EgoParams:
    """Constants of the car, read from a single env's World so they are the same floats."""

    mass: float
    lf: float
    lr: float
    wheelbase: float
    yaw_inertia: float
    max_long: float
    c_front: float
    c_rear: float
    max_front: float
    max_rear: float
    min_speed: float
    max_speed: float
    max_rpm: float
    min_rpm: float
    accel: float
    decel_brake: float
    decel_free: float
    engine_on: bool
    suppress_cruise_off: bool
    ratios: np.ndarray  # gear 1..n
    reverse_ratio: float
    power_table: np.ndarray
    gear_table: np.ndarray
    reset_pose: tuple[float, float, float, float]
    initial_speed: float
    initial_gear: int
    initial_rpm: float
    initial_fuel: float

    @staticmethod
    def from_world(world: Any) -> EgoParams:
        ego = world.ego
        body, pt, car = ego.body, ego.powertrain, ego.car
        if type(body).__name__ != "FastVehicle":
            raise ValueError("the native batch simulates the fast backend only")
        if body.ground_height is not None:
            raise ValueError("the native batch supports flat ground only")
        if car.cruise_control.acc:
            raise ValueError("the native batch does not model adaptive cruise control")
        if not car.transmission.automatic:
            raise ValueError("the native batch models the automatic gearbox only")
        spec = body.spec
        pose = world.start_pose
        return EgoParams(
            mass=spec.mass_kg,
            lf=spec.cog_to_front_m,
            lr=spec.wheelbase_m - spec.cog_to_front_m,
            wheelbase=spec.wheelbase_m,
            yaw_inertia=spec.yaw_inertia,
            max_long=body._max_long,
            c_front=body._c_front,
            c_rear=body._c_rear,
            max_front=body._max_front,
            max_rear=body._max_rear,
            min_speed=ego.min_speed_mps,
            max_speed=pt.engine.max_speed_mps,
            max_rpm=pt.engine.max_rpm,
            min_rpm=pt.engine.min_rpm,
            accel=pt.engine.acceleration_mps2,
            decel_brake=pt.brake.deceleration_brake_mps2,
            decel_free=pt.brake.deceleration_free_wheel_mps2,
            engine_on=bool(ego._initial_powertrain.engine_on),
            suppress_cruise_off=bool(car.cruise_control.suppress_deactivation_by_brake),
            ratios=np.asarray(pt.ratios, dtype=np.float64),
            reverse_ratio=float(pt.reverse_ratio),
            power_table=np.asarray(pt._power_table, dtype=np.float64),
            gear_table=np.asarray(pt._best_gear_table, dtype=np.int64),
            reset_pose=(float(pose.position_m[0]), float(pose.position_m[1]), float(pose.position_m[2]), float(pose.yaw_rad)),
            initial_speed=float(car.cruise_control.initial_speed_mps),
            initial_gear=int(ego._initial_powertrain.gear),
            initial_rpm=float(ego._initial_powertrain.rpm),
            initial_fuel=float(ego._initial_powertrain.fuel_left_l),
        )


@dataclass
class EgoArrays:
    """The changing state of N ego cars (one row each)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    yaw: np.ndarray
    u: np.ndarray
    v: np.ndarray
    r: np.ndarray
    gear: np.ndarray
    rpm: np.ndarray
    prev_v: np.ndarray
    fuel_used: np.ndarray
    fuel_left: np.ndarray
    steer_in: np.ndarray  # CarInputs as applied (after cruise control and minSpeed)
    gas_in: np.ndarray
    brake_in: np.ndarray
    cruise_on: np.ndarray
    cruise_target: np.ndarray
    cruise_int: np.ndarray  # the cruise controller's integral (EgoCar.cruise_integral)

    @staticmethod
    def zeros(n: int) -> EgoArrays:
        kw: dict[str, np.ndarray] = {f.name: np.zeros(n) for f in fields(EgoArrays)}
        kw["gear"] = np.zeros(n, dtype=np.int64)
        kw["cruise_on"] = np.zeros(n, dtype=bool)
        return EgoArrays(**kw)

    def take(self, idx: np.ndarray) -> EgoArrays:
        return EgoArrays(**{f.name: getattr(self, f.name)[idx] for f in fields(self)})

    def put(self, idx: np.ndarray, part: EgoArrays) -> None:
        for f in fields(self):
            getattr(self, f.name)[idx] = getattr(part, f.name)


def reset_rows(p: EgoParams, s: EgoArrays, idx: np.ndarray) -> None:
    """`EgoCar.reset(start pose)` for the rows `idx`."""
    x, y, z, yaw = p.reset_pose
    speed = p.initial_speed
    s.x[idx], s.y[idx], s.z[idx], s.yaw[idx] = x, y, z, yaw
    s.u[idx], s.v[idx], s.r[idx] = speed, 0.0, 0.0
    s.gear[idx], s.rpm[idx], s.prev_v[idx] = p.initial_gear, p.initial_rpm, speed
    s.fuel_used[idx], s.fuel_left[idx] = 0.0, p.initial_fuel
    s.steer_in[idx] = s.gas_in[idx] = s.brake_in[idx] = 0.0
    s.cruise_on[idx], s.cruise_target[idx], s.cruise_int[idx] = speed > 0.0, speed, 0.0


def _inner_friction(rpm: np.ndarray) -> np.ndarray:
    return 7e-7 * rpm * rpm - 5e-4 * rpm + 10.9


def _full_power(p: EgoParams, rpm: np.ndarray) -> np.ndarray:
    x = np.minimum(np.maximum(rpm, ptm.POWER_RPM_MIN), ptm.POWER_RPM_MAX) - ptm.POWER_RPM_MIN
    q = x / ptm._RPM_TABLE_STEP
    i = q.astype(np.int64)  # int() of a non-negative float
    last = len(p.power_table) - 1
    ic = np.minimum(i, last - 1)
    t0, t1 = p.power_table[ic], p.power_table[ic + 1]
    return np.where(i >= last, p.power_table[-1], t0 + (t1 - t0) * (q - i))


def step(p: EgoParams, s: EgoArrays, dt: float, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One physics step of every row of `s` (in place). Returns the front-wheel angle and the
    applied gas for callers that need them."""
    v0 = s.u
    # ---- EgoCar: cruise control (no ACC) and the engine's minSpeed
    if not p.suppress_cruise_off:
        s.cruise_on &= ~(brake > 0.0)
    err = s.cruise_target - v0
    on = s.cruise_on
    near = on & (err > -CRUISE_INTEGRAL_BAND_MPS) & (err < CRUISE_INTEGRAL_BAND_MPS)
    s.cruise_int = np.where(near, np.minimum(CRUISE_INTEGRAL_MAX, np.maximum(0.0, s.cruise_int + CRUISE_KI * err * dt)), s.cruise_int)
    throttle = CRUISE_GAIN * err + s.cruise_int
    gas = np.where(on & (throttle > 0), np.maximum(gas, np.minimum(1.0, throttle)), gas)
    brake = np.where(on & (err < -1.0), np.maximum(brake, np.minimum(1.0, -CRUISE_GAIN * (err + 1.0) * 0.5)), brake)
    if p.min_speed > 0.0:
        low = (brake == 0.0) & (s.gear > 0) & (v0 < p.min_speed)
        gas = np.where(low, np.maximum(gas, np.minimum(1.0, CRUISE_GAIN * (p.min_speed - v0) + 0.3)), gas)
    s.steer_in, s.gas_in, s.brake_in = steer, gas, brake
    drive, brake_force = _powertrain(p, s, dt, v0, gas, brake)
    _body(p, s, dt, steer * MAX_WHEEL_ANGLE_RAD, drive, brake_force)
    return drive, gas


def _powertrain(
    p: EgoParams, s: EgoArrays, dt: float, v_mps: np.ndarray, gas: np.ndarray, brake: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    m = p.mass
    speed = np.abs(v_mps)
    i = (speed / ptm._TABLE_STEP + 0.5).astype(np.int64)
    all_fwd = bool(np.all(s.gear > 0))
    best = p.gear_table[np.minimum(i, len(p.gear_table) - 1)]
    s.gear = best if all_fwd else np.where(s.gear > 0, best, s.gear)
    gear = s.gear
    fwd = gear > 0
    if not p.engine_on:
        gas = np.zeros_like(gas)
    over = speed * 3.6 - (p.max_speed * 3.6 - 1.0)
    capped = fwd & (over > 0.0)
    gas = np.where(s.fuel_left <= 0.0, 0.0, np.where(capped, gas * np.where(over >= 1.0, 0.0, 1.0 - over), gas))
    ratio = p.ratios[gear - 1] if all_fwd else np.where(fwd, p.ratios[np.maximum(gear, 1) - 1], np.where(gear < 0, p.reverse_ratio, 0.0))
    gear_rpm_now = speed * 3.6 * ratio / ptm.WHEEL_CONSTANT
    if p.engine_on:
        clamp = np.where(gear_rpm_now > p.max_rpm, p.max_rpm, np.where(gear_rpm_now < p.min_rpm, p.min_rpm, gear_rpm_now))
        target = clamp if all_fwd else np.where(gear == 0, gas * p.max_rpm, clamp)
    else:
        target = np.zeros_like(speed)
    max_change = ptm.RPM_RATE_LIMIT * dt
    d = target - s.rpm
    s.rpm = s.rpm + np.where(d > max_change, max_change, np.where(d < -max_change, -max_change, d))
    rpm = s.rpm
    dv = speed - np.abs(s.prev_v)
    s.prev_v = v_mps
    p_engine = _full_power(p, rpm) * gas if p.engine_on else np.zeros_like(rpm)
    if not all_fwd:
        p_engine = np.where(gear != 0, p_engine, 0.0)
    inner = _inner_friction(rpm) if p.engine_on else np.full_like(rpm, 10.9)
    p_load = (
        (
            ptm.ROLLING_COEFF * m * ptm.G * speed
            + ptm._AIR_K * speed * speed * speed
            + 0.5 * ptm.INERTIA_MASS_FACTOR * m * dv * np.abs(dv) / dt
        )
        / 1000.0
        + ptm.ACCESSORIES_KW
        + inner
    )
    # drive force
    p_wheel = p_engine - ptm.ACCESSORIES_KW - _inner_friction(rpm)
    can = (gas > 0.0) & (gear != 0) & (gear_rpm_now <= p.max_rpm) & (p_wheel > 0.0) & p.engine_on
    v_eff = np.where(speed > ptm.MIN_DRIVE_SPEED, speed, ptm.MIN_DRIVE_SPEED)
    drive = np.minimum(1000.0 * p_wheel / v_eff, m * p.accel * gas)
    drive = np.where(can, np.where(gear < 0, -drive, drive), 0.0)
    # brakes and drag
    brake_force = brake * m * p.decel_brake
    coeff = (p_load - p_engine - 10.0) / 50.0
    coeff = np.where(coeff < 0.2, 0.2, np.where(coeff > 1.0, 1.0, coeff))
    on_gas = gas > 0.0
    brake_force = brake_force + np.where(on_gas, ptm.ROLLING_COEFF * m * ptm.G + ptm._AIR_K * speed * speed, m * p.decel_free * coeff)
    # fuel (OpenDS's formula; the consumption display is not kept here)
    factor = np.where(rpm <= 3600.0, 1.0, np.where(rpm >= 4800.0, 1.5, 1.0 + 0.5 * (rpm - 3600.0) / 1200.0))
    litres = np.where(p_engine > 0.0, p_engine * dt / ptm.FUEL_LHV_KJ_PER_G * factor / ptm.FUEL_DENSITY_G_PER_L, 0.0)
    if p.engine_on:
        litres = np.where((litres == 0.0) & (rpm <= p.min_rpm + 1e-6), ptm.IDLE_FUEL_L_PER_S * dt, litres)
    s.fuel_used = s.fuel_used + litres
    s.fuel_left = np.maximum(0.0, s.fuel_left - litres)
    return drive, brake_force


def _body(p: EgoParams, s: EgoArrays, dt: float, steer_rad: np.ndarray, drive: np.ndarray, brake_force: np.ndarray) -> None:
    m, lf, lr = p.mass, p.lf, p.lr
    u, v, r = s.u, s.v, s.r
    fx = np.where(drive > p.max_long, p.max_long, np.where(drive < -p.max_long, -p.max_long, drive))
    brake = np.where(brake_force < p.max_long, brake_force, p.max_long)
    # the common case, every car moving forward faster than DYNAMIC_ABOVE, skips the branches
    # that cannot apply (the same operations on the same values otherwise)
    cruising = bool(np.all(u >= DYNAMIC_ABOVE))
    if cruising:
        fx = fx - brake
        uu = u
    else:
        still = (u == 0.0) & (-brake <= fx) & (fx <= brake)
        fx = np.where(u > 0.0, fx - brake, np.where(u < 0.0, fx + brake, np.where(still, 0.0, fx - np.copysign(brake, fx))))
        au = np.abs(u)
        w_dyn = np.where(
            au < DYNAMIC_ABOVE, np.where(au <= KINEMATIC_BELOW, 0.0, (au - KINEMATIC_BELOW) / (DYNAMIC_ABOVE - KINEMATIC_BELOW)), 1.0
        )
        uu = np.where(au > 0.5, u, np.copysign(0.5, np.where(u != 0.0, u, 1.0)))
    u_new = u + fx / m * dt
    # dynamic bicycle model (computed for all rows, used where w_dyn > 0)
    cos_d = np.cos(steer_rad)
    sin_d = np.sin(steer_rad)
    if cruising:  # sign = 1.0: 1.0 * a == a and -1.0 * a == -a exactly
        alpha_f = steer_rad - libm.arctan((v + lf * r) / uu)
        alpha_r = -libm.arctan((v - lr * r) / uu)
    else:
        sign = np.where(uu > 0.0, 1.0, -1.0)
        alpha_f = sign * (steer_rad - libm.arctan((v + lf * r) / uu))
        alpha_r = -sign * libm.arctan((v - lr * r) / uu)
    fyf = p.max_front * libm.tanh(p.c_front * alpha_f / p.max_front)
    fyr = p.max_rear * libm.tanh(p.c_rear * alpha_r / p.max_rear)
    dv_dyn = (fyf * cos_d + fyr + 0.0) / m - u * r
    dr_dyn = (lf * fyf * cos_d - lr * fyr) / p.yaw_inertia
    if cruising:
        u_new = u_new + (-fyf * sin_d / m + v * r) * dt
        v_new = v + dv_dyn * dt
        r_new = r + dr_dyn * dt
        kin = np.zeros(0, dtype=np.int64)
    else:
        dyn = w_dyn > 0.0
        u_new = np.where(dyn, u_new + (-fyf * sin_d / m + v * r) * dt, u_new)
        v_new = np.where(dyn, v + dv_dyn * dt, 0.0)
        r_new = np.where(dyn, r + dr_dyn * dt, 0.0)
        kin = np.flatnonzero(w_dyn < 1.0)
    if kin.size:  # kinematic bicycle model at walking pace (rare: compute on those rows only)
        sk, uk, wk = steer_rad[kin], u_new[kin], w_dyn[kin]
        tan_d = libm.tan(sk)
        beta = libm.arctan(lr * tan_d / p.wheelbase)
        r_kin = uk * np.cos(beta) * tan_d / p.wheelbase
        v_kin = uk * libm.tan(beta)
        v_new[kin] = wk * v_new[kin] + (1.0 - wk) * v_kin
        r_new[kin] = wk * r_new[kin] + (1.0 - wk) * r_kin
    held = np.abs(drive) <= brake
    if cruising:
        u_new = np.where((u_new < 0.0) & held, 0.0, u_new)
    else:
        u_new = np.where((((u > 0.0) & (u_new < 0.0)) | ((u < 0.0) & (u_new > 0.0))) & held, 0.0, u_new)
    stop = (np.abs(u_new) < STOP_SPEED) & (np.abs(drive) <= brake + 1e-9)
    s.u = np.where(stop, 0.0, u_new)
    s.v = np.where(stop, 0.0, v_new)
    s.r = np.where(stop, 0.0, r_new)
    s.yaw = s.yaw + s.r * dt
    sy, cy = np.sin(s.yaw), np.cos(s.yaw)
    s.x = s.x + (-s.u * sy - s.v * cy) * dt
    s.z = s.z + (-s.u * cy + s.v * sy) * dt


def check_finite_pose(s: EgoArrays) -> None:
    if not (np.all(np.isfinite(s.x)) and np.all(np.isfinite(s.z))):
        bad = int(np.flatnonzero(~(np.isfinite(s.x) & np.isfinite(s.z)))[0])
        raise FloatingPointError(f"env {bad}: the ego pose is not finite")
