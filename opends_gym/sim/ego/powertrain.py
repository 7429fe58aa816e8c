"""OpenDS's powertrain: engine power, load terms, gears, rpm, brakes and fuel.

Why: human-factors users compare speeds, fuel use and engine behaviour with OpenDS, so the
formulas are OpenDS's own (its `PowerTrain`, `Transmission` and `SteeringCar.update`;
docs/opends-compatibility.md#vehicle-model), in SI units, per physics step: P_accel = max(0, P_engine - P_load) becomes the engine force
30 x P_accel x powerPercentage (jME's `accelerate()`, twice on each front wheel), the
automatic gearbox picks the gear of the highest fitted power-percentage polynomial, and
the brakes are Bullet brake impulses per wheel: pedal x maxBrakeForce plus the free-wheel
friction coefficient x maxFreeWheelBrakeForce. There are no separate rolling or air
forces: in OpenDS they act only through P_load (the engine force and the free-wheel drag).

The per-step maths is a compiled kernel (`ego.step.powertrain_step`), shared with the
native batch; the Python functions here are the formulas, for tests and tables.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ...task.model_car import Car
from . import kernels as ek
from . import step as ef
from .kernels import (  # the constants the compiled powertrain uses too: one definition
    ACCESSORIES_KW,
    BRAKE_FORCE_PER_DECEL_KG,
    FUEL_LHV_KJ_PER_G,
    INERTIA_MASS_FACTOR,
    POWER_RPM_MAX,
    POWER_RPM_MIN,
    ROLLING_COEFF,
    WHEEL_CONSTANT,
    G,
)
from .kernels import PER_RPM_TABLE_STEP as _PER_RPM_TABLE_STEP
from .kernels import RPM_TABLE_STEP as _RPM_TABLE_STEP
from .kernels import TABLE_STEP as _TABLE_STEP

BMEP_COEFFS = (-19950.8, 3479.90, -231.809, 8.25775, -0.169919, 0.00202259, -1.2921e-5, 3.42208e-8)  # kPa, n in 1/s
RHO_AIR = 1.3  # kg/m^3 (ego.kernels.AIR_K = 0.5 x RHO_AIR x CW x FRONTAL_AREA_M2)
CW = 0.3
FRONTAL_AREA_M2 = 2.0
CONSUMPTION_WINDOW_S = 2.0
CONSUMPTION_UPDATE_S = 0.5
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


_STATE_FIELDS = {
    "gear": (ef.S_GEAR, int),  # -1 reverse, 0 neutral, 1..n forward
    "automatic": (ef.S_AUTOMATIC, bool),
    "engine_on": (ef.S_ENGINE_ON, bool),
    "rpm": (ef.S_RPM, float),
    "prev_v_mps": (ef.S_PREV_V, float),
    "fuel_used_l": (ef.S_FUEL_USED, float),
    "fuel_left_l": (ef.S_FUEL_LEFT, float),
    "p_engine_kw": (ef.S_P_ENGINE, float),
    "p_load_kw": (ef.S_P_LOAD, float),
    # consumption display (OpenDS: 2 s window, refreshed every 500 ms)
    "window_l": (ef.S_WINDOW_L, float),
    "window_m": (ef.S_WINDOW_M, float),
    "since_update_s": (ef.S_SINCE_UPDATE, float),
    "l_per_100km": (ef.S_L_PER_100KM, float),
    "l_per_h": (ef.S_L_PER_H, float),
    "t_s": (ef.S_T, float),
    "odometer_m": (ef.S_ODOMETER, float),
}
_RING_ROWS = 256  # the display window's rows (t, litres, metres); grown when a small dt needs more


class PowertrainState:
    """The powertrain's changing state. The values live in one float array (`values`, slots
    `ego.step.S_*`) that the compiled step updates in place; the attributes read and write
    it. `ring` holds the consumption display's 2 s window."""

    gear: int
    automatic: bool
    engine_on: bool
    rpm: float
    prev_v_mps: float
    fuel_used_l: float
    fuel_left_l: float
    p_engine_kw: float
    p_load_kw: float
    window_l: float
    window_m: float
    since_update_s: float
    l_per_100km: float
    l_per_h: float
    t_s: float
    odometer_m: float

    def __init__(self, **values: float) -> None:
        self.values = np.zeros(ef.N_STATE)
        self.ring = np.zeros((_RING_ROWS, 3))
        defaults = {"gear": 1, "automatic": True, "engine_on": True, "fuel_left_l": 60.0}
        for name, value in (defaults | values).items():
            if name not in _STATE_FIELDS:
                raise TypeError(f"PowertrainState has no field {name!r}")
            setattr(self, name, value)

    def ensure_ring_room(self) -> None:
        """Keep a free row in the display window (the window holds 2 s of steps)."""
        count = int(self.values[ef.S_RING_COUNT])
        if count + 1 < len(self.ring):
            return
        head = int(self.values[ef.S_RING_HEAD])
        order = (head + np.arange(count)) % len(self.ring)
        ring = np.zeros((2 * len(self.ring), 3))
        ring[:count] = self.ring[order]
        self.ring = ring
        self.values[ef.S_RING_HEAD] = 0.0

    def __repr__(self) -> str:
        return "PowertrainState(" + ", ".join(f"{k}={getattr(self, k)!r}" for k in _STATE_FIELDS) + ")"


def _state_property(slot: int, kind: type) -> property:
    def get(self: PowertrainState) -> object:
        return kind(self.values[slot])

    def put(self: PowertrainState, value: float) -> None:
        self.values[slot] = float(value)

    return property(get, put)


for _name, (_slot, _kind) in _STATE_FIELDS.items():
    setattr(PowertrainState, _name, _state_property(_slot, _kind))


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
        self._dec_brake, self._dec_free = car.brake.deceleration_brake_mps2, car.brake.deceleration_free_wheel_mps2
        self._build_gear_table()
        # constants of the per-step maths, looked up once (the car blocks are frozen)
        self._max_rpm, self._min_rpm = self.engine.max_rpm, self.engine.min_rpm
        self._dec_brake, self._dec_free = self.brake.deceleration_brake_mps2, self.brake.deceleration_free_wheel_mps2
        params = np.zeros(8)
        params[ek.P_MASS], params[ek.P_MAX_RPM], params[ek.P_MIN_RPM] = mass_kg, self._max_rpm, self._min_rpm
        params[ek.P_MAX_SPEED_KMH] = self.engine.max_speed_mps * 3.6
        params[ek.P_MAX_BRAKE] = self.max_brake_impulse
        params[ek.P_MAX_FREE_WHEEL] = self.max_free_wheel_impulse
        params[ek.P_REVERSE_RATIO] = self.reverse_ratio
        self._tables = (
            params,
            np.asarray(self.ratios, float),
            np.asarray(self._power_table, float),
            np.asarray(self._best_gear_table, float),
        )
        self._car = ek.car_constants(np.zeros(10), *self._tables)  # (no body: the backend has its own)

    @property
    def max_brake_impulse(self) -> float:
        """OpenDS's maxBrakeForce = 0.004375 x decelerationBrake x mass: Bullet's brake
        value, an impulse (N s) per wheel per 0.01 s Bullet step (SteeringCar's constructor)."""
        return BRAKE_FORCE_PER_DECEL_KG * self._dec_brake * self.mass_kg

    @property
    def max_free_wheel_impulse(self) -> float:
        """maxFreeWheelBrakeForce = 0.004375 x decelerationFreeWheel x mass (as above)."""
        return BRAKE_FORCE_PER_DECEL_KG * self._dec_free * self.mass_kg

    # ------------------------------------------------------------------ gears
    def power_share(self, gear: int, v_mps: float) -> float:
        """OpenDS's `Transmission.getPowerPercentage` at speed v: the share (0..1) of the
        engine's power the gear passes on (its fitted polynomial in v / 140 km/h)."""
        return float(ek.power_percentage_py(gear, abs(v_mps) * 3.6 / ek.SPEED_AT_FULL_SHARE_KMH))

    def _build_gear_table(self) -> None:
        """Best forward gear per 0.1 m/s of speed (`Transmission.findBestPowerGear`), for tables and the native batch."""
        n = min(len(self.ratios), 6)
        speeds = np.arange(0.0, _TABLE_MAX_SPEED, _TABLE_STEP)
        self._best_gear_table = [int(ek.best_power_gear_py(n, float(v) * 3.6 / ek.SPEED_AT_FULL_SHARE_KMH)) for v in speeds]

    def best_gear(self, v_mps: float) -> int:
        """Automatic gearbox: the forward gear of highest power percentage (no hysteresis, as OpenDS)."""
        n = min(len(self.ratios), 6)
        return int(ek.best_power_gear_py(n, abs(v_mps) * 3.6 / ek.SPEED_AT_FULL_SHARE_KMH))

    def shift(self, gear: int) -> None:
        """Manual shift request: -1 reverse, 0 neutral, 1..n forward."""
        self.state.gear = max(-1, min(len(self.ratios), gear))

    # ------------------------------------------------------------------ step
    def _full_power_kw(self, rpm: float) -> float:
        """Engine power at full gas (kW), interpolated from a 10-rpm table built once."""
        x = (POWER_RPM_MIN if rpm < POWER_RPM_MIN else POWER_RPM_MAX if rpm > POWER_RPM_MAX else rpm) - POWER_RPM_MIN
        i = int(x * _PER_RPM_TABLE_STEP)  # (as `kernels.full_power_kw`)
        table = self._power_table
        if i >= len(table) - 1:
            return table[-1]
        f = x * _PER_RPM_TABLE_STEP - i
        return table[i] + (table[i + 1] - table[i]) * f

    def forces(
        self, dt_s: float, v_mps: float, gas: float, brake: float, pitch_rad: float = 0.0, hand_brake: bool = False
    ) -> tuple[float, float]:
        """Advance one physics step at forward speed v (negative when rolling backwards) with
        the chassis at `pitch_rad` (positive nose up; OpenDS's slope is pitch - 0.031765 rad,
        `Car.getSlope`); (drive force N, brake force N). The maths is `ego.kernels.powertrain_step`."""
        st = self.state
        if st.values[ef.S_RING_COUNT] + 2.0 > len(st.ring):
            st.ensure_ring_room()
        return ef.powertrain_step(self._car, st.values, st.ring, dt_s, v_mps, gas, brake, pitch_rad, hand_brake)  # type: ignore[no-any-return]

    def step(
        self, dt_s: float, v_mps: float, gas: float, brake: float, pitch_rad: float = 0.0, hand_brake: bool = False
    ) -> PowertrainOutput:
        """`forces` with the step's rpm and gear."""
        drive, brake_force = self.forces(dt_s, v_mps, gas, brake, pitch_rad, hand_brake)
        return PowertrainOutput(drive, brake_force, self.state.rpm, self.state.gear)
