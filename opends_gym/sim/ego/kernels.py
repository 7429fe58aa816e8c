"""The ego car's per-step maths as compiled kernels: fast-backend body and powertrain.

Why: these run every physics step of every env. Each is one scalar function of one car,
called by the single env (`FastVehicle.step`, `Powertrain.step`) and, in a loop over
envs, by the native batch (`opends_gym.vector.ego`), so both compute the same floats by
construction. The expressions keep the operand order of the Python they replaced, and the
kernels use C-library `math` like CPython (`sim.jit`), so results did not change.

Units: SI (m, s, kg, N, rad); powers in kW and rpm as in OpenDS's formulas
(`sim.powertrain`). Parameter and state slots are the constants below.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import inline, kernel

KINEMATIC_BELOW = 1.0  # m/s: purely kinematic below this forward speed
DYNAMIC_ABOVE = 3.0  # m/s: purely dynamic above this
STOP_SPEED = 0.05  # m/s: at rest below this when no drive force

# body parameters (`body_params`)
B_MASS, B_LF, B_LR, B_WHEELBASE, B_YAW_INERTIA, B_MAX_LONG, B_C_FRONT, B_C_REAR, B_MAX_FRONT, B_MAX_REAR = range(10)

# powertrain parameters (offsets in the powertrain block of `car_constants`)
P_MASS, P_MAX_RPM, P_MIN_RPM, P_ACCEL, P_DEC_BRAKE, P_DEC_FREE, P_CAP_FROM_KMH, P_REVERSE_RATIO = range(8)
# `car_constants`: the body parameters, the powertrain parameters, then the tables' lengths and the tables
C_BODY, C_PT, C_N_RATIOS, C_N_POWER, C_N_GEARS, C_TABLES = 0, 10, 18, 19, 20, 21

G = 9.81
ROLLING_COEFF = 0.008
AIR_K = 0.5 * 1.3 * 0.3 * 2.0  # 0.5 rho_air c_w A
ACCESSORIES_KW = 0.75
INERTIA_MASS_FACTOR = 1.03
FUEL_LHV_KJ_PER_G = 43.7
FUEL_DENSITY_G_PER_L = 760.0
IDLE_FUEL_L_PER_S = 0.0003
WHEEL_CONSTANT = 380.0 * 0.00006  # rpm = v_kmh * ratio / WHEEL_CONSTANT
RPM_RATE_LIMIT = 5000.0  # rpm per second
POWER_RPM_MIN, POWER_RPM_MAX = 1500.0, 5100.0
MIN_DRIVE_SPEED = 2.0  # m/s: below this, drive force is the engine-block acceleration cap
TABLE_STEP = 0.1  # m/s resolution of the automatic gearbox table
RPM_TABLE_STEP = 10.0
CRUISE_GAIN = 0.5  # throttle (or brake) per m/s of speed error
CRUISE_KI = 0.3  # throttle per (m/s x s): the integral holds the set speed against drag
CRUISE_INTEGRAL_BAND_MPS = 2.0  # integrate only this close to the set speed (no wind-up)
CRUISE_INTEGRAL_MAX = 0.8


def body_params(
    mass: float,
    lf: float,
    wheelbase: float,
    yaw_inertia: float,
    max_long: float,
    c_front: float,
    c_rear: float,
    max_front: float,
    max_rear: float,
) -> np.ndarray:
    p = np.zeros(10)
    p[B_MASS], p[B_LF], p[B_LR], p[B_WHEELBASE], p[B_YAW_INERTIA] = mass, lf, wheelbase - lf, wheelbase, yaw_inertia
    p[B_MAX_LONG], p[B_C_FRONT], p[B_C_REAR], p[B_MAX_FRONT], p[B_MAX_REAR] = max_long, c_front, c_rear, max_front, max_rear
    return p


def car_constants(body: np.ndarray, pt: np.ndarray, ratios: np.ndarray, power_table: np.ndarray, gear_table: np.ndarray) -> np.ndarray:
    """One array of a car's constants for the kernels: the body's `body_params` first (so it
    serves `body_step` as is), the powertrain's parameters, the gear ratios, the full-gas
    power table (10-rpm steps from 1500 rpm) and the automatic gearbox's table (0.1 m/s
    steps). One array, not five: each array a kernel passes on costs a reference count."""
    head = np.zeros(C_TABLES)
    head[C_BODY : C_BODY + 10], head[C_PT : C_PT + 8] = body, pt
    head[C_N_RATIOS], head[C_N_POWER], head[C_N_GEARS] = len(ratios), len(power_table), len(gear_table)
    return np.concatenate([head, ratios, power_table, np.asarray(gear_table, dtype=np.float64)])


@inline
def body_step(
    p: np.ndarray,
    x: float,
    z: float,
    yaw: float,
    u: float,
    v: float,
    r: float,
    dt: float,
    steer_rad: float,
    drive_n: float,
    brake_n: float,
    side_n: float,
) -> tuple[float, float, float, float, float, float]:
    """One step of the single-track model: (x, z, yaw, u, v, r) after `dt`.

    x, z m; yaw rad (0 faces -Z); u forward, v left m/s; r rad/s; forces N.
    """
    x, z, yaw, u, v, r, _, _ = body_step_trig(
        p, x, z, yaw, u, v, r, dt, steer_rad, math.cos(steer_rad), math.sin(steer_rad), drive_n, brake_n, side_n
    )
    return x, z, yaw, u, v, r


@inline
def body_step_trig(p: np.ndarray, x: float, z: float, yaw: float, u: float, v: float, r: float, dt: float, steer_rad: float, cos_d: float,
                   sin_d: float, drive_n: float, brake_n: float,
                   side_n: float) -> tuple[float, float, float, float, float, float, float, float]:  # fmt: skip
    """`body_step` given the cosine and sine of the steering angle, also returning the sine and
    cosine of the new heading: a caller that holds the steering for several steps computes
    them once, and one that needs the heading's (a box's centre) reuses them."""
    m, lf, lr = p[B_MASS], p[B_LF], p[B_LR]
    max_long = p[B_MAX_LONG]
    # longitudinal force: drive minus brakes (brakes oppose motion, never reverse it)
    fx = drive_n
    if fx > max_long:
        fx = max_long
    elif fx < -max_long:
        fx = -max_long
    brake = brake_n if brake_n < max_long else max_long
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
    u_new = u + fx / m * dt
    v_dyn = r_dyn = 0.0
    if w_dyn > 0.0:
        # dynamic bicycle model with tanh-saturated tyre forces
        uu = u if au > 0.5 else math.copysign(0.5, u if u != 0.0 else 1.0)
        # slip angles; the force opposes the tyre's sideways slip, so reversing flips them
        sign = 1.0 if uu > 0.0 else -1.0
        alpha_f = sign * (steer_rad - math.atan((v + lf * r) / uu))
        alpha_r = -sign * math.atan((v - lr * r) / uu)
        fyf = p[B_MAX_FRONT] * math.tanh(p[B_C_FRONT] * alpha_f / p[B_MAX_FRONT])
        fyr = p[B_MAX_REAR] * math.tanh(p[B_C_REAR] * alpha_r / p[B_MAX_REAR])
        dv_dyn = (fyf * cos_d + fyr + side_n) / m - u * r
        dr_dyn = (lf * fyf * cos_d - lr * fyr) / p[B_YAW_INERTIA]
        u_new += (-fyf * sin_d / m + v * r) * dt
        v_dyn = v + dv_dyn * dt
        r_dyn = r + dr_dyn * dt
    if w_dyn < 1.0:
        # kinematic bicycle model: no tyre slip at walking pace
        wb = p[B_WHEELBASE]
        tan_d = math.tan(steer_rad)
        beta = math.atan(lr * tan_d / wb)
        r_kin = u_new * math.cos(beta) * tan_d / wb
        v_kin = u_new * math.tan(beta)
        v_new = w_dyn * v_dyn + (1.0 - w_dyn) * v_kin
        r_new = w_dyn * r_dyn + (1.0 - w_dyn) * r_kin
    else:
        v_new, r_new = v_dyn, r_dyn
    # brakes stop the car; they do not push it backwards
    if (u > 0.0 > u_new or u < 0.0 < u_new) and abs(drive_n) <= brake:
        u_new = 0.0
    if abs(u_new) < STOP_SPEED and abs(drive_n) <= brake + 1e-9:
        u_new = v_new = r_new = 0.0
    yaw = yaw + r_new * dt
    sy, cy = math.sin(yaw), math.cos(yaw)
    # forward (-sin, -cos), left (-cos, +sin) in (x, z)
    x = x + (-u_new * sy - v_new * cy) * dt
    z = z + (-u_new * cy + v_new * sy) * dt
    return x, z, yaw, u_new, v_new, r_new, sy, cy


@inline
def full_power_kw(car: np.ndarray, rpm: float) -> float:
    """Engine power at full gas (kW), interpolated in the 10-rpm table from 1500 rpm."""
    x = (POWER_RPM_MIN if rpm < POWER_RPM_MIN else POWER_RPM_MAX if rpm > POWER_RPM_MAX else rpm) - POWER_RPM_MIN
    i = int(x / RPM_TABLE_STEP)
    a = C_TABLES + int(car[C_N_RATIOS])
    last = int(car[C_N_POWER]) - 1
    if i >= last:
        return float(car[a + last])
    f = x / RPM_TABLE_STEP - i
    return float(car[a + i] + (car[a + i + 1] - car[a + i]) * f)


@inline
def powertrain_core(car: np.ndarray, gear: int, automatic: bool, engine_on: bool, rpm: float, prev_v: float, fuel_used: float,
                    fuel_left: float, dt: float, v_mps: float, gas: float, brake: float, slope_rad: float,
                    hand_brake: bool) -> tuple[int, float, float, float, float, float, float, float, float]:  # fmt: skip
    """One powertrain step at forward speed v (m/s, negative rolling backwards); `car` is
    `car_constants`.

    Returns (gear, rpm, drive N, brake N, P_engine kW, P_load kW, fuel litres this step,
    fuel used L, fuel left L); see `sim.powertrain` for the formulas.
    """
    n_ratios, n_gears = int(car[C_N_RATIOS]), int(car[C_N_GEARS])
    gears = C_TABLES + n_ratios + int(car[C_N_POWER])
    speed = -v_mps if v_mps < 0.0 else v_mps
    if automatic and gear > 0:
        i = int(speed / TABLE_STEP + 0.5)
        gear = int(car[gears + i]) if i < n_gears else int(car[gears + n_gears - 1])
    max_rpm, min_rpm = car[C_PT + P_MAX_RPM], car[C_PT + P_MIN_RPM]
    if not engine_on or fuel_left <= 0.0:
        gas = 0.0
    elif gear > 0:
        # OpenDS's speed cap: power scaled by (maxSpeed - v) in the last km/h, 0 above
        over = speed * 3.6 - car[C_PT + P_CAP_FROM_KMH]
        if over > 0.0:
            gas *= 0.0 if over >= 1.0 else 1.0 - over
    ratio = car[C_PT + P_REVERSE_RATIO] if gear < 0 else car[C_TABLES + gear - 1] if gear > 0 else 0.0
    gear_rpm_now = speed * 3.6 * ratio / WHEEL_CONSTANT
    if not engine_on:
        target_rpm = 0.0
    elif gear == 0:
        target_rpm = gas * max_rpm
    else:
        target_rpm = max_rpm if gear_rpm_now > max_rpm else min_rpm if gear_rpm_now < min_rpm else gear_rpm_now
    max_change = RPM_RATE_LIMIT * dt
    d_rpm = target_rpm - rpm
    rpm += max_change if d_rpm > max_change else -max_change if d_rpm < -max_change else d_rpm
    # power balance (kW), OpenDS's terms
    prev = -prev_v if prev_v < 0.0 else prev_v
    dv = speed - prev
    p_engine = full_power_kw(car, rpm) * gas if engine_on and gear != 0 else 0.0
    m = car[C_PT + P_MASS]
    sin_slope = (math.sin(-slope_rad if gear < 0 else slope_rad)) if slope_rad != 0.0 else 0.0
    inner_kw = 7e-7 * rpm * rpm - 5e-4 * rpm + 10.9
    p_load = (
        (
            ROLLING_COEFF * m * G * speed
            + AIR_K * speed * speed * speed
            + 0.5 * INERTIA_MASS_FACTOR * m * dv * (dv if dv > 0 else -dv) / dt
            + m * G * speed * sin_slope
        )
        / 1000.0
        + ACCESSORIES_KW
        + (inner_kw if engine_on else 10.9)
    )
    # drive force: P_accel = P_engine - P_load, with the road loads as body forces and the
    # inertia term being the acceleration itself; accessories and engine friction remain
    drive = 0.0
    if gas > 0.0 and gear != 0 and engine_on and gear_rpm_now <= max_rpm:
        p_wheel_kw = p_engine - ACCESSORIES_KW - inner_kw
        if p_wheel_kw > 0.0:
            v = speed if speed > MIN_DRIVE_SPEED else MIN_DRIVE_SPEED
            cap = m * car[C_PT + P_ACCEL] * gas
            drive = 1000.0 * p_wheel_kw / v
            if drive > cap:
                drive = cap
            if gear < 0:
                drive = -drive
    # brakes: pedal, hand brake, and the engine/free-wheel drag when off the gas
    brake_force = brake * m * car[C_PT + P_DEC_BRAKE]
    if hand_brake:
        held = m * car[C_PT + P_DEC_BRAKE] * 0.6
        brake_force = held if held > brake_force else brake_force
    if gas > 0.0:
        # rolling and air resistance; off the gas OpenDS's free-wheel drag stands for them
        brake_force += ROLLING_COEFF * m * G + AIR_K * speed * speed
    else:
        surplus_kw = p_load - p_engine
        coeff = (surplus_kw - 10.0) / 50.0
        coeff = 0.2 if coeff < 0.2 else 1.0 if coeff > 1.0 else coeff
        brake_force += m * car[C_PT + P_DEC_FREE] * coeff
    # fuel: grams = P_engine dt / 43.7 kJ/g, times 1..1.5 above 3600 rpm; idle 0.0003 L/s
    litres = 0.0
    if p_engine > 0.0:
        factor = 1.0 if rpm <= 3600.0 else 1.5 if rpm >= 4800.0 else 1.0 + 0.5 * (rpm - 3600.0) / 1200.0
        litres = p_engine * dt / FUEL_LHV_KJ_PER_G * factor / FUEL_DENSITY_G_PER_L
    if litres == 0.0 and engine_on and rpm <= min_rpm + 1e-6:
        litres = IDLE_FUEL_L_PER_S * dt
    fuel_used += litres
    rest = fuel_left - litres
    fuel_left = rest if rest > 0.0 else 0.0
    return gear, rpm, drive, brake_force, p_engine, p_load, litres, fuel_used, fuel_left


@inline
def cruise_control(on: bool, target: float, integral: float, v: float, gas: float, brake: float, dt: float, suppress_off: bool,
                   acc: bool, emergency_m: float, safety_m: float, lead_gap: float,
                   lead_v: float) -> tuple[float, float, bool, float]:  # fmt: skip
    """Cruise control and ACC, a PI speed controller: (gas, brake, on, integral) after one step.

    The brake pedal switches it off (unless `suppress_off`); with ACC (`acc`) a lead car
    `lead_gap` m ahead at `lead_v` m/s (NaN: none) lowers the set speed to its speed inside
    the safety distance (`safety_m`, 0: half the speed in km/h, as metres) and to 0 inside
    `emergency_m` (NaN: none). Speeds m/s, pedals 0..1.
    """
    if on and brake > 0.0 and not suppress_off:
        on = False
    if on:
        goal = target
        if acc and not math.isnan(lead_gap):
            if not math.isnan(emergency_m) and lead_gap < emergency_m:
                goal = 0.0
            elif lead_gap < (safety_m if safety_m else 0.5 * v * 3.6):
                goal = lead_v if lead_v < goal else goal
        err = goal - v
        if -CRUISE_INTEGRAL_BAND_MPS < err < CRUISE_INTEGRAL_BAND_MPS:
            i = integral + CRUISE_KI * err * dt
            i = i if i > 0.0 else 0.0
            integral = i if i < CRUISE_INTEGRAL_MAX else CRUISE_INTEGRAL_MAX
        throttle = CRUISE_GAIN * err + integral
        if throttle > 0:
            t = throttle if throttle < 1.0 else 1.0
            gas = t if t > gas else gas
        if err < -1.0:
            b = -CRUISE_GAIN * (err + 1.0) * 0.5
            b = b if b < 1.0 else 1.0
            brake = b if b > brake else brake
    return gas, brake, on, integral


@inline
def min_speed_gas(gas: float, brake: float, v: float, gear: int, min_speed: float) -> float:
    """The engine block's minSpeed: OpenDS keeps the car at least this fast off the brake."""
    if min_speed > 0.0 and brake == 0.0 and v < min_speed and gear > 0:
        g = CRUISE_GAIN * (min_speed - v) + 0.3
        g = g if g < 1.0 else 1.0
        gas = g if g > gas else gas
    return gas


@kernel
def body_step_kernel(p: np.ndarray, x: float, z: float, yaw: float, u: float, v: float, r: float, dt: float, steer_rad: float,
                     drive_n: float, brake_n: float, side_n: float) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """`body_step` for callers in Python (inlined functions are compiled for kernels only)."""
    return body_step(p, x, z, yaw, u, v, r, dt, steer_rad, drive_n, brake_n, side_n)
