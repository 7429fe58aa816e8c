"""OpenDS's powertrain: engine power, load terms, gears, rpm, brakes and fuel.

Why: human-factors users compare fuel use and engine behaviour with OpenDS, so the
formulas are OpenDS's (OPENDS.md section 5), in SI units, per physics step. Where OpenDS
turned the surplus power P_accel = P_engine - P_load into a game-engine force with a tuning
constant (`30 x P_accel x powerShare`), we apply it physically (F = P_accel / v, capped by
the engine block's `acceleration`), with the road loads (tyre, air, grade) as forces on the
body. The gear "power share" OpenDS read from fitted per-gear polynomials is computed from
the same bmep engine curve (the fitted coefficients are not public) and picks the gear.
Both are documented deviations; fuel follows OpenDS's formula exactly.

Pure Python floats: this runs every physics step of every env, where numpy scalars cost
more than they save.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..task.model_car import Car

G = 9.81
BMEP_COEFFS = (-19950.8, 3479.90, -231.809, 8.25775, -0.169919, 0.00202259, -1.2921e-5, 3.42208e-8)  # kPa, n in 1/s
RHO_AIR = 1.3  # kg/m^3
CW = 0.3
FRONTAL_AREA_M2 = 2.0
ROLLING_COEFF = 0.008
ACCESSORIES_KW = 0.75
INERTIA_MASS_FACTOR = 1.03
FUEL_LHV_KJ_PER_G = 43.7
FUEL_DENSITY_G_PER_L = 760.0
IDLE_FUEL_L_PER_S = 0.0003
WHEEL_CONSTANT = 380.0 * 0.00006  # rpm = v_kmh * ratio / WHEEL_CONSTANT
RPM_RATE_LIMIT = 5000.0  # rpm per second
POWER_RPM_MIN, POWER_RPM_MAX = 1500.0, 5100.0
CONSUMPTION_WINDOW_S = 2.0
CONSUMPTION_UPDATE_S = 0.5
MIN_DRIVE_SPEED = 2.0  # m/s: below this, drive force is the engine-block acceleration cap
_TABLE_STEP = 0.1  # m/s resolution of the automatic gearbox table
_RPM_TABLE_STEP = 10.0
_AIR_K = 0.5 * RHO_AIR * CW * FRONTAL_AREA_M2
_TABLE_MAX_SPEED = 120.0


def bmep_kpa(n_per_s: float) -> float:
    """Brake mean effective pressure (kPa) at engine speed n (revolutions per second)."""
    x = 1.0
    total = 0.0
    for c in BMEP_COEFFS:
        total += c * x
        x *= n_per_s
    return total


def engine_power_kw(rpm: float, gas: float, displacement_m3: float) -> float:
    """P_engine = bmep(n) * n * V_d / 2 * |gas|, with rpm clamped to 1500..5100 (kW)."""
    r = POWER_RPM_MIN if rpm < POWER_RPM_MIN else POWER_RPM_MAX if rpm > POWER_RPM_MAX else rpm
    n = r / 60.0
    return bmep_kpa(n) * n * displacement_m3 * 0.5 * abs(gas)


def inner_friction_kw(rpm: float) -> float:
    """Engine friction power 7e-7 rpm^2 - 5e-4 rpm + 10.9 (kW)."""
    return 7e-7 * rpm * rpm - 5e-4 * rpm + 10.9


@dataclass(frozen=True)
class LoadTerms:
    """The six OpenDS load terms in kW."""

    tire_kw: float
    air_kw: float
    inertia_kw: float
    grade_kw: float
    accessories_kw: float
    inner_kw: float

    @property
    def total_kw(self) -> float:
        return self.tire_kw + self.air_kw + self.inertia_kw + self.grade_kw + self.accessories_kw + self.inner_kw


def load_terms(mass_kg: float, v_mps: float, dv_mps: float, dt_s: float, slope_rad: float, rpm: float, reverse: bool = False) -> LoadTerms:
    """OpenDS's power balance loads at speed v after a speed change dv over dt."""
    v = abs(v_mps)
    slope = -slope_rad if reverse else slope_rad
    return LoadTerms(
        tire_kw=ROLLING_COEFF * mass_kg * G * v / 1000.0,
        air_kw=0.5 * RHO_AIR * CW * FRONTAL_AREA_M2 * v**3 / 1000.0,
        inertia_kw=0.5 * INERTIA_MASS_FACTOR * mass_kg * dv_mps * abs(dv_mps) / dt_s / 1000.0 if dt_s > 0 else 0.0,
        grade_kw=mass_kg * G * v * math.sin(slope) / 1000.0,
        accessories_kw=ACCESSORIES_KW,
        inner_kw=inner_friction_kw(rpm),
    )


def gear_rpm(v_mps: float, ratio: float) -> float:
    """rpm = |v_kmh * ratio / (380 * 0.00006)|."""
    return abs(v_mps * 3.6 * ratio / WHEEL_CONSTANT)


def fuel_rpm_factor(rpm: float) -> float:
    """1 up to 3600 rpm, rising linearly to 1.5 at 4800 rpm and above."""
    if rpm <= 3600.0:
        return 1.0
    if rpm >= 4800.0:
        return 1.5
    return 1.0 + 0.5 * (rpm - 3600.0) / 1200.0


def fuel_grams(p_engine_kw: float, dt_s: float, rpm: float) -> float:
    """grams = P_engine * dt / 43.7 kJ/g, times the high-rpm factor."""
    return p_engine_kw * dt_s / FUEL_LHV_KJ_PER_G * fuel_rpm_factor(rpm)


@dataclass
class PowertrainState:
    gear: int = 1  # -1 reverse, 0 neutral, 1..n forward
    automatic: bool = True
    engine_on: bool = True
    rpm: float = 0.0
    prev_v_mps: float = 0.0
    fuel_used_l: float = 0.0
    fuel_left_l: float = 60.0
    p_engine_kw: float = 0.0
    p_load_kw: float = 0.0
    # consumption display (OpenDS: 2 s window, refreshed every 500 ms)
    window: deque[tuple[float, float, float]] = field(default_factory=deque)  # (t, litres, metres)
    window_l: float = 0.0
    window_m: float = 0.0
    since_update_s: float = 0.0
    l_per_100km: float = 0.0
    l_per_h: float = 0.0
    t_s: float = 0.0
    odometer_m: float = 0.0


class PowertrainOutput(NamedTuple):
    """One step's result (a named tuple: built every physics step, so it must be cheap)."""

    drive_force_n: float  # along the car's forward axis (negative in reverse)
    brake_force_n: float  # magnitude, opposes motion: brakes plus rolling/air or free-wheel drag
    rpm: float
    gear: int


class Powertrain:
    """Engine, gearbox, brakes and fuel of one car, built from the scenario's `car` block."""

    def __init__(self, car: Car, mass_kg: float) -> None:
        self.mass_kg = mass_kg
        self.engine = car.engine
        self.transmission = car.transmission
        self.brake = car.brake
        self.ratios = tuple(car.transmission.forward_ratios) or (1.0,)
        self.reverse_ratio = car.transmission.reverse_ratio
        rpms = np.arange(POWER_RPM_MIN, POWER_RPM_MAX + _RPM_TABLE_STEP, _RPM_TABLE_STEP)
        self._power_table = [engine_power_kw(float(r), 1.0, self.engine.displacement_m3) for r in rpms]
        self.max_power_kw = max(self._power_table)
        self.state = PowertrainState(automatic=car.transmission.automatic, engine_on=car.engine.engine_on, fuel_left_l=car.fuel.start_l)
        self._build_gear_table()
        # constants of the per-step maths, looked up once (the car blocks are frozen)
        self._cap_from_kmh = self.engine.max_speed_mps * 3.6 - 1.0
        self._max_rpm, self._min_rpm = self.engine.max_rpm, self.engine.min_rpm
        self._accel_mps2 = self.engine.acceleration_mps2
        self._dec_brake, self._dec_free = self.brake.deceleration_brake_mps2, self.brake.deceleration_free_wheel_mps2

    # ------------------------------------------------------------------ gears
    def power_share(self, gear: int, v_mps: float) -> float:
        """Share (0..1) of the engine's maximum power available in `gear` at speed v."""
        ratio = self.reverse_ratio if gear < 0 else self.ratios[gear - 1]
        rpm = gear_rpm(v_mps, ratio)
        if rpm > self.engine.max_rpm:
            return 0.0
        share = self._full_power_kw(rpm) / self.max_power_kw
        return 0.0 if share < 0.0 else 1.0 if share > 1.0 else share

    def _build_gear_table(self) -> None:
        """Best forward gear per 0.1 m/s of speed, so the automatic costs one lookup a step."""
        speeds = np.arange(0.0, _TABLE_MAX_SPEED, _TABLE_STEP)
        shares = np.array([[self.power_share(g, float(v)) for v in speeds] for g in range(1, len(self.ratios) + 1)])
        # OpenDS's power curve is clamped flat outside 1500..5100 rpm, so gears tie there; a
        # tie goes to the gear whose rpm lies closest to that band (1st when crawling, the
        # top gear at motorway speed) instead of to whichever comes first
        rpm = np.array([[gear_rpm(float(v), r) for v in speeds] for r in self.ratios])
        outside = np.maximum(POWER_RPM_MIN - rpm, 0.0) + np.maximum(rpm - POWER_RPM_MAX, 0.0)
        self._best_gear_table = (np.argmax(shares - 1e-9 * outside, axis=0) + 1).tolist()

    def best_gear(self, v_mps: float) -> int:
        """Automatic gearbox: the forward gear of highest power share (no hysteresis, as OpenDS)."""
        i = int(abs(v_mps) / _TABLE_STEP + 0.5)
        table = self._best_gear_table
        return table[i] if i < len(table) else table[-1]

    def shift(self, gear: int) -> None:
        """Manual shift request: -1 reverse, 0 neutral, 1..n forward."""
        self.state.gear = max(-1, min(len(self.ratios), gear))

    # ------------------------------------------------------------------ step
    def _full_power_kw(self, rpm: float) -> float:
        """Engine power at full gas (kW), interpolated from a 10-rpm table built once."""
        x = (POWER_RPM_MIN if rpm < POWER_RPM_MIN else POWER_RPM_MAX if rpm > POWER_RPM_MAX else rpm) - POWER_RPM_MIN
        i = int(x / _RPM_TABLE_STEP)
        table = self._power_table
        if i >= len(table) - 1:
            return table[-1]
        f = x / _RPM_TABLE_STEP - i
        return table[i] + (table[i + 1] - table[i]) * f

    def step(
        self, dt_s: float, v_mps: float, gas: float, brake: float, slope_rad: float = 0.0, hand_brake: bool = False
    ) -> PowertrainOutput:
        """Advance one physics step at forward speed v (negative when rolling backwards)."""
        st = self.state
        st.t_s += dt_s
        speed = -v_mps if v_mps < 0.0 else v_mps
        if st.automatic and st.gear > 0:
            st.gear = self.best_gear(speed)
        gear = st.gear
        engine_on = st.engine_on
        max_rpm = self._max_rpm
        if not engine_on or st.fuel_left_l <= 0.0:
            gas = 0.0
        elif gear > 0:
            # OpenDS's speed cap: power scaled by (maxSpeed - v) in the last km/h, 0 above
            over = speed * 3.6 - self._cap_from_kmh
            if over > 0.0:
                gas *= 0.0 if over >= 1.0 else 1.0 - over
        ratio = self.reverse_ratio if gear < 0 else self.ratios[gear - 1] if gear > 0 else 0.0
        gear_rpm_now = speed * 3.6 * ratio / WHEEL_CONSTANT
        if not engine_on:
            target_rpm = 0.0
        elif gear == 0:
            target_rpm = gas * max_rpm
        else:
            target_rpm = max_rpm if gear_rpm_now > max_rpm else self._min_rpm if gear_rpm_now < self._min_rpm else gear_rpm_now
        max_change = RPM_RATE_LIMIT * dt_s
        d_rpm = target_rpm - st.rpm
        st.rpm += max_change if d_rpm > max_change else -max_change if d_rpm < -max_change else d_rpm
        rpm = st.rpm
        # power balance (kW), OpenDS's terms
        prev = -st.prev_v_mps if st.prev_v_mps < 0.0 else st.prev_v_mps
        dv = speed - prev
        st.prev_v_mps = v_mps
        p_engine = self._full_power_kw(rpm) * gas if engine_on and gear != 0 else 0.0
        m = self.mass_kg
        sin_slope = math.sin(-slope_rad if gear < 0 else slope_rad) if slope_rad else 0.0
        inner_kw = inner_friction_kw(rpm)
        p_load = (
            (
                ROLLING_COEFF * m * G * speed
                + _AIR_K * speed * speed * speed
                + 0.5 * INERTIA_MASS_FACTOR * m * dv * (dv if dv > 0 else -dv) / dt_s
                + m * G * speed * sin_slope
            )
            / 1000.0
            + ACCESSORIES_KW
            + (inner_kw if engine_on else 10.9)
        )
        st.p_engine_kw = p_engine
        st.p_load_kw = p_load
        # drive force: OpenDS's P_accel = P_engine - P_load, with the road loads (tyre, air,
        # grade) applied as forces on the body below and the inertia term being the
        # acceleration itself; what remains to subtract are accessories and engine friction
        drive = 0.0
        if gas > 0.0 and gear != 0 and engine_on and gear_rpm_now <= max_rpm:
            p_wheel_kw = p_engine - ACCESSORIES_KW - inner_kw
            if p_wheel_kw > 0.0:
                v = speed if speed > MIN_DRIVE_SPEED else MIN_DRIVE_SPEED
                cap = m * self._accel_mps2 * gas
                drive = 1000.0 * p_wheel_kw / v
                if drive > cap:
                    drive = cap
                if gear < 0:
                    drive = -drive
        # brakes: pedal, hand brake, and the engine/free-wheel drag when off the gas
        brake_force = brake * m * self._dec_brake
        if hand_brake:
            brake_force = max(brake_force, m * self._dec_brake * 0.6)
        if gas > 0.0:
            # rolling and air resistance; off the gas OpenDS's free-wheel drag stands for them
            brake_force += ROLLING_COEFF * m * G + _AIR_K * speed * speed
        else:
            surplus_kw = p_load - p_engine
            coeff = (surplus_kw - 10.0) / 50.0
            coeff = 0.2 if coeff < 0.2 else 1.0 if coeff > 1.0 else coeff
            brake_force += m * self._dec_free * coeff
        self._fuel(dt_s, p_engine, rpm, speed)
        return PowertrainOutput(drive, brake_force, rpm, gear)

    def _fuel(self, dt_s: float, p_engine_kw: float, rpm: float, v_mps: float) -> None:
        st = self.state
        litres = fuel_grams(p_engine_kw, dt_s, rpm) / FUEL_DENSITY_G_PER_L if p_engine_kw > 0.0 else 0.0
        if litres == 0.0 and st.engine_on and rpm <= self.engine.min_rpm + 1e-6:
            litres = IDLE_FUEL_L_PER_S * dt_s
        st.fuel_used_l += litres
        st.fuel_left_l = max(0.0, st.fuel_left_l - litres)
        dist = v_mps * dt_s
        st.odometer_m += dist
        win = st.window
        win.append((st.t_s, litres, dist))
        st.window_l += litres
        st.window_m += dist
        while win and st.t_s - win[0][0] >= CONSUMPTION_WINDOW_S - 1e-9:
            _, old_l, old_m = win.popleft()
            st.window_l -= old_l
            st.window_m -= old_m
        st.since_update_s += dt_s
        if st.since_update_s >= CONSUMPTION_UPDATE_S - 1e-9:
            st.since_update_s = 0.0
            span = min(CONSUMPTION_WINDOW_S, st.t_s)
            st.l_per_h = st.window_l / span * 3600.0 if span > 0 else 0.0
            st.l_per_100km = st.window_l / st.window_m * 100_000.0 if st.window_m > 1e-3 else 0.0
