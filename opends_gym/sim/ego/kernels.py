"""The ego car's per-step maths as compiled kernels: fast-backend body and powertrain.

Why: these run every physics step of every env. Each is one scalar function of one car,
called by the single env (`FastVehicle.step`, `Powertrain.step`) and, in a loop over
envs, by the native batch (`opends_gym.vector.ego`), so both compute the same floats by
construction; run as Python (`NUMBA_DISABLE_JIT`) they compute the same floats too (C
library `math` as CPython's, no fused multiply-add: `jit`). Two changes for speed moved
results by an ulp or so against the Python they replaced (2026-11-27): divisions by
constants became multiplications by their reciprocals, and the automatic's gear is looked
up among precomputed speed breaks (`gearbox`).

Units: SI (m, s, kg, N, rad); powers in kW and rpm as in OpenDS's formulas
(`sim.powertrain`). Parameter and state slots are the constants below.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import inline, kernel
from .gearbox import GEAR_BREAKS, GEAR_RUNS, MAX_GEARS, clamped_share

SIDE_DAMPING = 0.2  # Bullet's resolveSingleBilateral: share of a wheel's sideways sliding removed per OpenDS tick
FORWARD_SLIP_FACTOR = 0.5  # btRaycastVehicle::updateFriction's fwdFactor in the friction circle
REST_SPEED = 0.01  # m/s: a braked, undriven car slower than this is at rest
# OpenDS's Bullet step: `Simulator.simpleInitDrivingTask` sets the physics space's accuracy to
# 0.01 s. Its brake values are impulses per wheel per tick, and its tyres remove SIDE_DAMPING of
# the sliding per tick; at another step the same share per 0.01 s is removed (side_share).
OPENDS_TICK_S = 0.01

# body parameters (`body_params`)
B_MASS, B_LF, B_LR, B_WHEELBASE, B_YAW_INERTIA, B_HALF_TRACK, B_FRICTION_SLIP, B_LOAD_FRONT, B_LOAD_REAR, B_ROLL_TERM = range(10)

# powertrain parameters (offsets in the powertrain block of `car_constants`)
P_MASS, P_MAX_RPM, P_MIN_RPM, P_MAX_SPEED_KMH, P_MAX_BRAKE, P_MAX_FREE_WHEEL, P_SPARE, P_REVERSE_RATIO = range(8)
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
ENGINE_FORCE_PER_KW = 30.0  # SteeringCar.update: accelerate(30 x P_accel x powerPercentage)
SPEED_AT_FULL_SHARE_KMH = 140.0  # Transmission.speedAt100PercentMarker
# Car.getSlope: OpenDS's slope is the chassis pitch less 0.031765 rad (its "correction due to
# different suspension heights"), so a level chassis reads 1.8 degrees downhill and P_grade
# (m g v sin(slope)) lowers the load on flat ground: its real drives show it (the AudiS6 of the
# Countryside logs rests at pitch +0.003 rad on flat road, slope -0.029).
SLOPE_PITCH_OFFSET_RAD = 0.031765
BRAKE_FORCE_PER_DECEL_KG = 0.004375  # SteeringCar: maxBrakeForce = 0.004375 x decelerationBrake x mass
TABLE_STEP = 0.1  # m/s resolution of the automatic gearbox table
RPM_TABLE_STEP = 10.0
# Divisions by constants as multiplications by their reciprocals: a division costs several multiplications, and the car
# divided by these at every physics step (docs/performance.md, round 14). The products differ from the quotients in the last
# bit at most.
PER_RPM_TABLE_STEP = 1.0 / RPM_TABLE_STEP
RPM_PER_KMH = 1.0 / WHEEL_CONSTANT
KW_PER_W = 1.0 / 1000.0
OPENDS_TICKS_PER_S = 1.0 / OPENDS_TICK_S
SHARE_PER_KMH = 1.0 / SPEED_AT_FULL_SHARE_KMH
LITRES_PER_KJ = 1.0 / (FUEL_LHV_KJ_PER_G * FUEL_DENSITY_G_PER_L)  # kJ / (kJ/g) / (g/L)
CRUISE_GAIN = 0.5  # throttle (or brake) per m/s of speed error
CRUISE_KI = 0.3  # throttle per (m/s x s): the integral holds the set speed against drag
CRUISE_INTEGRAL_BAND_MPS = 2.0  # integrate only this close to the set speed (no wind-up)
CRUISE_INTEGRAL_MAX = 0.8


def body_params(mass: float, lf: float, wheelbase: float, yaw_inertia: float, half_track: float, friction_slip: float,
                gravity: float = G, cog_height: float = 0.0, roll_inertia: float = math.inf) -> np.ndarray:  # fmt: skip
    """The planar raycast vehicle's constants; a wheel's load is its static share of the weight.
    `cog_height` and `roll_inertia` give the sideways impulse's denominator its roll term
    (the contact lies below the centre of gravity, as in Bullet's 3-D jacobian)."""
    p = np.zeros(10)
    lr = wheelbase - lf
    p[B_MASS], p[B_LF], p[B_LR], p[B_WHEELBASE], p[B_YAW_INERTIA] = mass, lf, lr, wheelbase, yaw_inertia
    p[B_HALF_TRACK], p[B_FRICTION_SLIP] = half_track, friction_slip
    p[B_LOAD_FRONT], p[B_LOAD_REAR] = 0.5 * mass * gravity * lr / wheelbase, 0.5 * mass * gravity * lf / wheelbase
    p[B_ROLL_TERM] = cog_height * cog_height / roll_inertia
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
def side_share(dt: float) -> float:
    """The share of a wheel's sideways sliding its impulse removes in a step of dt: OpenDS's
    SIDE_DAMPING per 0.01 s tick, compounded (exactly SIDE_DAMPING at dt = 0.01 s)."""
    compounded = 1.0 - (1.0 - SIDE_DAMPING) ** (dt / OPENDS_TICK_S)  # (unconditional: a loop's compiler hoists it)
    return SIDE_DAMPING if dt == OPENDS_TICK_S else compounded


@inline
def body_step_trig(p: np.ndarray, x: float, z: float, yaw: float, u: float, v: float, r: float, dt: float, steer_rad: float, cos_d: float,
                   sin_d: float, drive_n: float, brake_n: float,
                   side_n: float) -> tuple[float, float, float, float, float, float, float, float]:  # fmt: skip
    """`body_step` given the cosine and sine of the steering angle, also returning the sine and
    cosine of the new heading: a caller that holds the steering for several steps computes
    them once, and one that needs the heading's (a box's centre) reuses them.

    The step is Bullet's `btRaycastVehicle::updateFriction` in the ground plane: per wheel a
    sideways impulse of 0.2 x the sliding speed x the effective mass at the contact
    (`resolveSingleBilateral`), a forward impulse of engine force x dt on driven wheels or
    rolling friction capped by the brake impulse on the others (`calcRollingFriction`), both
    scaled down together when they exceed load x dt x frictionSlip; then the body moves.
    """
    w = wheel_constants(p, dt, cos_d, sin_d)
    return body_step_wheels(p, w, x, z, yaw, u, v, r, dt, cos_d, sin_d, drive_n, brake_n, side_n)


# `wheel_constants`: 1/mass, 1/yaw inertia, the sideways share, then per wheel (front left, front right, rear left, rear right)
# the reciprocal of the sideways effective-mass denominator and a quarter of the forward one's reciprocal, then the front and
# the rear wheel's impulse limit (reciprocals: see PER_RPM_TABLE_STEP)
W_INV_M, W_INV_I, W_SIDE, W_INV_SIDE, W_INV_FWD, W_MAX_FRONT, W_MAX_REAR = 0, 1, 2, 3, 7, 11, 12


@inline
def wheel_constants(p: np.ndarray, dt: float, cos_d: float, sin_d: float) -> tuple[float, ...]:
    """What `body_step_wheels` needs of the car (`body_params`), the step and the steering
    angle's cosine and sine (slots W_*): constant while the steering is held, so a caller that
    runs several physics steps of one policy step computes them once (the same expressions,
    so the same floats)."""
    m, lf, lr, ht, inertia = p[B_MASS], p[B_LF], p[B_LR], p[B_HALF_TRACK], p[B_YAW_INERTIA]
    inv_m, inv_i = 1.0 / m, 1.0 / inertia
    slip = p[B_FRICTION_SLIP]
    roll_term = p[B_ROLL_TERM]
    s0, f0 = _wheel_denominators(lf, ht, cos_d, sin_d, inv_m, inv_i, roll_term)
    s1, f1 = _wheel_denominators(lf, -ht, cos_d, sin_d, inv_m, inv_i, roll_term)
    s2, f2 = _wheel_denominators(-lr, ht, 1.0, 0.0, inv_m, inv_i, roll_term)
    s3, f3 = _wheel_denominators(-lr, -ht, 1.0, 0.0, inv_m, inv_i, roll_term)
    return (
        inv_m,
        inv_i,
        side_share(dt),
        1.0 / s0,
        1.0 / s1,
        1.0 / s2,
        1.0 / s3,
        0.25 / f0,
        0.25 / f1,
        0.25 / f2,
        0.25 / f3,
        p[B_LOAD_FRONT] * dt * slip,
        p[B_LOAD_REAR] * dt * slip,
    )


@inline
def _wheel_denominators(a: float, b: float, fc: float, fs: float, inv_m: float, inv_i: float, roll_term: float) -> tuple[float, float]:
    """A wheel's sideways and forward effective-mass denominators (contact at a ahead, b left
    of the centre of gravity; forward axis (fc, fs))."""
    arm = a * fc + b * fs  # p x axle
    arm_f = a * fs - b * fc  # p x forward
    return inv_m + arm * arm * inv_i + roll_term, inv_m + arm_f * arm_f * inv_i


@inline
def body_step_wheels(p: np.ndarray, wc: tuple[float, ...], x: float, z: float, yaw: float, u: float, v: float, r: float, dt: float,
                     cos_d: float, sin_d: float, drive_n: float, brake_n: float,
                     side_n: float) -> tuple[float, float, float, float, float, float, float, float]:  # fmt: skip
    """`body_step_trig` with the car's `wheel_constants` for this step and steering given."""
    lf, lr, ht = p[B_LF], p[B_LR], p[B_HALF_TRACK]
    inv_m, inv_i, side = wc[W_INV_M], wc[W_INV_I], wc[W_SIDE]
    # OpenDS's CarControl.accelerate: twice the engine force on each front wheel, none behind
    front_force = 0.5 * drive_n
    brake_imp = 0.25 * brake_n * dt  # per wheel (brake_n: the four wheels' force over a step)
    du = dv = dr = 0.0
    for w in range(4):
        a = lf if w < 2 else -lr
        b = ht if w % 2 == 0 else -ht
        if w < 2:
            fc, fs = cos_d, sin_d  # forward axis of a steered wheel (forward, left components)
            max_imp = wc[W_MAX_FRONT]
        else:
            fc, fs = 1.0, 0.0
            max_imp = wc[W_MAX_REAR]
        # contact velocity (forward, left)
        pu = u - r * b
        pv = v + r * a
        # sideways: the axle (-fs, fc)
        j_side = -side * (-fs * pu + fc * pv) * wc[W_INV_SIDE + w]
        # forward: engine force on the front wheels, else rolling friction up to the brake
        if w < 2 and front_force != 0.0:
            j_fwd = front_force * dt
        else:
            j_fwd = -(fc * pu + fs * pv) * wc[W_INV_FWD + w]
            if j_fwd > brake_imp:
                j_fwd = brake_imp
            elif j_fwd < -brake_imp:
                j_fwd = -brake_imp
        xf = j_fwd * FORWARD_SLIP_FACTOR
        sq = xf * xf + j_side * j_side
        if sq > max_imp * max_imp:
            k = max_imp / math.sqrt(sq)
            j_fwd *= k
            j_side *= k
        # the impulse in body axes and its moment
        ju = fc * j_fwd - fs * j_side
        jv = fs * j_fwd + fc * j_side
        du += ju
        dv += jv
        dr += a * jv - b * ju
    u_new = u + du * inv_m
    v_new = v + dv * inv_m + side_n * inv_m * dt
    r_new = r + dr * inv_i
    if -REST_SPEED < u_new < REST_SPEED and -REST_SPEED < v_new < REST_SPEED and drive_n == 0.0 and brake_n > 0.0:
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
    i = int(x * PER_RPM_TABLE_STEP)
    a = C_TABLES + int(car[C_N_RATIOS])
    last = int(car[C_N_POWER]) - 1
    if i >= last:
        return float(car[a + last])
    f = x * PER_RPM_TABLE_STEP - i
    return float(car[a + i] + (car[a + i + 1] - car[a + i]) * f)


# OpenDS's `Transmission.getPowerPercentage` (`gearbox.clamped_share`: one definition for the kernels and the gear breaks)
power_percentage = inline(clamped_share)


@inline
def best_power_gear(n_gears: int, speed_share: float) -> int:
    """`Transmission.findBestPowerGear` of a gearbox of n forward gears (at most 6 count):
    the forward gear of highest power percentage (the first on a tie; 1 when all are 0),
    looked up among the speed shares where the choice changes (`gearbox.GEAR_BREAKS`)."""
    if n_gears < 1:
        return 1
    row = (n_gears if n_gears < MAX_GEARS else MAX_GEARS) - 1
    k = 0
    while speed_share >= GEAR_BREAKS[row, k + 1]:
        k += 1
    return GEAR_RUNS[row, k]


@inline
def powertrain_core(car: np.ndarray, gear: int, automatic: bool, engine_on: bool, rpm: float, prev_v: float, fuel_used: float,
                    fuel_left: float, dt: float, v_mps: float, gas: float, brake: float, pitch_rad: float,
                    hand_brake: bool) -> tuple[int, float, float, float, float, float, float, float, float]:  # fmt: skip
    """One powertrain step at forward speed v (m/s, negative rolling backwards); `car` is
    `car_constants`. OpenDS's order: `Transmission.updateRPM`, `PowerTrain.getPAccel`,
    `Transmission.performAcceleration`, then the brake of `SteeringCar.update`. `pitch_rad`:
    the chassis pitch (jME's `toAngles()[0]`, positive nose up; 0 for a level chassis), from
    which the grade load takes OpenDS's slope (`Car.getSlope`, see SLOPE_PITCH_OFFSET_RAD).

    Returns (gear, rpm, drive N, brake N, P_engine kW, P_load kW, fuel litres this step,
    fuel used L, fuel left L). Drive: the four wheels' engine force (30 x P_accel x
    powerPercentage, twice on each front wheel); brake: the brake impulse per wheel per
    OpenDS tick as the four wheels' force. See `sim.powertrain` for the formulas.
    """
    n_ratios = int(car[C_N_RATIOS])
    speed = -v_mps if v_mps < 0.0 else v_mps
    speed_kmh = speed * 3.6
    max_rpm, min_rpm = car[C_PT + P_MAX_RPM], car[C_PT + P_MIN_RPM]
    if not engine_on or fuel_left <= 0.0:
        gas = 0.0
    # Transmission.updateRPM: the wheels' rpm in gear (gas x maxRPM in neutral), at least
    # minRPM with the engine on, changing by at most 5000 rpm/s
    ratio = car[C_PT + P_REVERSE_RATIO] if gear < 0 else car[C_TABLES + gear - 1] if gear > 0 else 0.0
    if gear == 0:
        target_rpm = (-gas if gas < 0.0 else gas) * max_rpm
    else:
        target_rpm = speed_kmh * ratio * RPM_PER_KMH
        target_rpm = max_rpm if target_rpm > max_rpm else target_rpm
    if engine_on and target_rpm < min_rpm:
        target_rpm = min_rpm
    max_change = RPM_RATE_LIMIT * dt
    d_rpm = target_rpm - rpm
    rpm += max_change if d_rpm > max_change else -max_change if d_rpm < -max_change else d_rpm
    # PowerTrain.getPAccel: P_accel = max(0, P_engine - P_load) (kW)
    prev = -prev_v if prev_v < 0.0 else prev_v
    dv = speed - prev
    p_engine = full_power_kw(car, rpm) * (-gas if gas < 0.0 else gas)
    m = car[C_PT + P_MASS]
    # Car.getSlope: the chassis pitch less a fixed 0.031765 rad ("due to different suspension heights")
    slope = pitch_rad - SLOPE_PITCH_OFFSET_RAD
    sin_slope = math.sin(-slope if gear < 0 else slope)
    inner_kw = 7e-7 * rpm * rpm - 5e-4 * rpm + 10.9
    p_load = (
        (
            ROLLING_COEFF * m * G * speed
            + AIR_K * speed * speed * speed
            + 0.5 * INERTIA_MASS_FACTOR * m * dv * (dv if dv > 0 else -dv) * (1.0 / dt)
            + m * G * speed * sin_slope
        )
        * KW_PER_W
        + ACCESSORIES_KW
        + inner_kw
    )
    p_accel = p_engine - p_load
    p_accel = p_accel if p_accel > 0.0 else 0.0
    surplus_kw = p_load - p_engine
    surplus_kw = surplus_kw if surplus_kw > 0.0 else 0.0
    # Transmission.performAcceleration: the automatic picks this step's best gear, the power
    # share is the previous gear's; near maxSpeed the share shrinks by (maxSpeed - v)
    share_gear = gear
    speed_share = speed_kmh * SHARE_PER_KMH
    pp = power_percentage(share_gear, speed_share)
    if automatic and gear > 0:
        gear = best_power_gear(n_ratios, speed_share)
    max_kmh = car[C_PT + P_MAX_SPEED_KMH]
    if speed_kmh >= max_kmh - 1.0:
        pp *= max_kmh - speed_kmh
    drive = 4.0 * ENGINE_FORCE_PER_KW * p_accel * pp
    if gas < 0.0:  # the "accelerate back" key: P_accel's sign is the pedal's (PowerTrain.getPAccel)
        drive = -drive
    if share_gear < 0:
        drive = -drive
    elif share_gear == 0:
        drive = 0.0
    # SteeringCar.update: hand brake, else pedal x maxBrakeForce + friction coefficient x
    # maxFreeWheelBrakeForce, the coefficient clamp((P_load - P_engine - 10) / 50, 0.2, 1)
    if hand_brake:
        per_wheel = car[C_PT + P_MAX_BRAKE]
    else:
        coeff = (surplus_kw - 10.0) * 0.02
        coeff = 0.2 if coeff < 0.2 else 1.0 if coeff > 1.0 else coeff
        per_wheel = brake * car[C_PT + P_MAX_BRAKE] + coeff * car[C_PT + P_MAX_FREE_WHEEL]
    brake_force = 4.0 * per_wheel * OPENDS_TICKS_PER_S
    # fuel: grams = P_engine dt / 43.7 kJ/g, times 1..1.5 above 3600 rpm; idle 0.0003 L/s
    litres = 0.0
    if p_engine > 0.0:
        factor = 1.0 if rpm <= 3600.0 else 1.5 if rpm >= 4800.0 else 1.0 + (rpm - 3600.0) * (0.5 / 1200.0)
        litres = p_engine * dt * factor * LITRES_PER_KJ
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


@kernel
def power_percentage_py(gear: int, speed_share: float) -> float:
    """`power_percentage` for callers in Python."""
    return power_percentage(gear, speed_share)


@kernel
def best_power_gear_py(n_gears: int, speed_share: float) -> int:
    """`best_power_gear` for callers in Python."""
    return best_power_gear(n_gears, speed_share)


@kernel
def side_share_py(dt: float) -> float:
    """`side_share` for callers in Python."""
    return side_share(dt)
