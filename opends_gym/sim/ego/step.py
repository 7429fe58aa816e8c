"""The single env's compiled ego step: inputs, cruise control, powertrain (with OpenDS's
consumption display) and the fast backend's body in one call.

Why: one physics step of the ego car is a few hundred floating-point operations; as Python
(or as several compiled calls) the call overhead dominated. The maths is the shared
kernels of `ego.kernels` (the native batch calls the same ones per env). Units: SI, rpm,
kW, litres, as there.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import kernel
from .kernels import G, body_step, cruise_control, min_speed_gas, powertrain_core

# the powertrain state (`sim.powertrain.PowertrainState.values`)
S_GEAR, S_AUTOMATIC, S_ENGINE_ON, S_RPM, S_PREV_V, S_FUEL_USED, S_FUEL_LEFT, S_P_ENGINE, S_P_LOAD = range(9)
S_WINDOW_L, S_WINDOW_M, S_SINCE_UPDATE, S_L_PER_100KM, S_L_PER_H, S_T, S_ODOMETER, S_RING_HEAD, S_RING_COUNT = range(9, 18)
N_STATE = 18
CONSUMPTION_WINDOW_S = 2.0
CONSUMPTION_UPDATE_S = 0.5
# the driver's-aid constants (`cruise_params`)
A_MIN_SPEED, A_SUPPRESS_OFF, A_ACC, A_EMERGENCY_M, A_SAFETY_M = range(5)


def cruise_params(min_speed_mps: float, suppress_off: bool, acc: bool, emergency_m: float | None, safety_m: float | None) -> np.ndarray:
    """The car's minSpeed and cruise-control settings for the kernels (None: NaN / 0)."""
    return np.array([min_speed_mps, suppress_off, acc, math.nan if emergency_m is None else emergency_m, safety_m or 0.0], dtype=float)


@kernel
def powertrain_step(car: np.ndarray, s: np.ndarray, ring: np.ndarray, dt: float, v_mps: float, gas: float, brake: float, pitch_rad: float,
                    hand_brake: bool) -> tuple[float, float]:  # fmt: skip
    """`powertrain_core` on the state slots `s`, plus the consumption display; (drive N, brake N).

    `ring` (rows t s, litres, metres) holds the display's 2 s window from row `s[S_RING_HEAD]`;
    the caller keeps a free row in it.
    """
    s[S_T] += dt
    gear, rpm, drive, brake_force, p_engine, p_load, litres, used, left = powertrain_core(
        car,
        int(s[S_GEAR]),
        s[S_AUTOMATIC] != 0.0,
        s[S_ENGINE_ON] != 0.0,
        s[S_RPM],
        s[S_PREV_V],
        s[S_FUEL_USED],
        s[S_FUEL_LEFT],
        dt,
        v_mps,
        gas,
        brake,
        pitch_rad,
        hand_brake,
    )
    s[S_GEAR], s[S_RPM], s[S_PREV_V], s[S_P_ENGINE], s[S_P_LOAD], s[S_FUEL_USED], s[S_FUEL_LEFT] = (
        gear,
        rpm,
        v_mps,
        p_engine,
        p_load,
        used,
        left,
    )
    # consumption display (OpenDS: 2 s window, refreshed every 500 ms)
    dist = (-v_mps if v_mps < 0.0 else v_mps) * dt
    s[S_ODOMETER] += dist
    cap = ring.shape[0]
    head, count = int(s[S_RING_HEAD]), int(s[S_RING_COUNT])
    k = (head + count) % cap
    ring[k, 0], ring[k, 1], ring[k, 2] = s[S_T], litres, dist
    count += 1
    s[S_WINDOW_L] += litres
    s[S_WINDOW_M] += dist
    while count > 0 and s[S_T] - ring[head, 0] >= CONSUMPTION_WINDOW_S - 1e-9:
        s[S_WINDOW_L] -= ring[head, 1]
        s[S_WINDOW_M] -= ring[head, 2]
        head = (head + 1) % cap
        count -= 1
    s[S_RING_HEAD], s[S_RING_COUNT] = head, count
    s[S_SINCE_UPDATE] += dt
    if s[S_SINCE_UPDATE] >= CONSUMPTION_UPDATE_S - 1e-9:
        s[S_SINCE_UPDATE] = 0.0
        t = s[S_T]
        span = t if t < CONSUMPTION_WINDOW_S else CONSUMPTION_WINDOW_S
        s[S_L_PER_H] = s[S_WINDOW_L] / span * 3600.0 if span > 0 else 0.0
        s[S_L_PER_100KM] = s[S_WINDOW_L] / s[S_WINDOW_M] * 100_000.0 if s[S_WINDOW_M] > 1e-3 else 0.0
    return drive, brake_force


@kernel
def drive_inputs(aid: np.ndarray, s: np.ndarray, v: float, gas: float, brake: float, dt: float, cruise_on: bool, cruise_target: float,
                 cruise_integral: float, lead_gap: float, lead_v: float) -> tuple[float, float, bool, float]:  # fmt: skip
    """The pedals after cruise control and minSpeed: (gas, brake, cruise on, cruise integral)."""
    gas, brake, cruise_on, cruise_integral = cruise_control(
        cruise_on, cruise_target, cruise_integral, v, gas, brake, dt, aid[A_SUPPRESS_OFF] != 0.0, aid[A_ACC] != 0.0, aid[A_EMERGENCY_M],
        aid[A_SAFETY_M], lead_gap, lead_v,
    )  # fmt: skip
    gas = min_speed_gas(gas, brake, v, int(s[S_GEAR]), aid[A_MIN_SPEED])
    return gas, brake, cruise_on, cruise_integral


@kernel
def ego_step(car: np.ndarray, aid: np.ndarray, s: np.ndarray, ring: np.ndarray, dt: float, steer_rad: float, gas: float, brake: float,
             clutch: float, hand_brake: bool, cruise_on: bool, cruise_target: float, cruise_integral: float, lead_gap: float,
             lead_v: float, x: float, z: float, yaw: float, u: float, v: float, r: float,
             pitch: float) -> tuple[float, float, float, float, float, float, int, float, float, bool, float]:  # fmt: skip
    """`drive_inputs`, `powertrain_step` and `body_step` of the single env's car: the body's
    (x, z, yaw, u, v, r), the free rows left in `ring`, the applied (gas, brake) and the cruise
    control's (on, integral). `pitch`: the road's slope ahead (rad, positive uphill; 0 on the
    flat road of every World), which pitches the chassis (the powertrain's grade load) and
    pulls the car back by g sin(pitch)."""
    gas, brake, cruise_on, cruise_integral = drive_inputs(
        aid, s, u, gas, brake, dt, cruise_on, cruise_target, cruise_integral, lead_gap, lead_v
    )
    # level chassis on a flat road: pitch 0, which OpenDS's Car.getSlope reads as slightly downhill
    drive, brake_n = powertrain_step(car, s, ring, dt, u, gas * (1.0 - clutch), brake, pitch, hand_brake)
    if pitch != 0.0:
        u -= G * math.sin(pitch) * dt
    x, z, yaw, u, v, r = body_step(car, x, z, yaw, u, v, r, dt, steer_rad, drive, brake_n, 0.0)
    return x, z, yaw, u, v, r, ring.shape[0] - int(s[S_RING_COUNT]), gas, brake, cruise_on, cruise_integral


@kernel
def ego_steps(car: np.ndarray, aid: np.ndarray, s: np.ndarray, ring: np.ndarray, dt: float, steer_rad: float, gas: float, brake: float,
              clutch: float, hand_brake: bool, cruise_on: bool, cruise_target: float, cruise_integral: float, lead_gap: float,
              lead_v: float, x: float, z: float, yaw: float, u: float, v: float, r: float, pitch: float,
              steps: int) -> tuple[float, float, float, float, float, float, int, bool, float]:  # fmt: skip
    """`ego_step` up to `steps` times with the same inputs on a road of constant slope (a look
    ahead, `EgoCar.ahead`): the body's (x, z, yaw, u, v, r), the steps done (fewer where `ring`
    has no free row left: grow it and go on) and the cruise control's (on, integral)."""
    done = 0
    while done < steps:
        x, z, yaw, u, v, r, free, _, _, cruise_on, cruise_integral = ego_step(
            car, aid, s, ring, dt, steer_rad, gas, brake, clutch, hand_brake, cruise_on, cruise_target, cruise_integral, lead_gap, lead_v,
            x, z, yaw, u, v, r, pitch,
        )  # fmt: skip
        done += 1
        if free < 2:
            break
    return x, z, yaw, u, v, r, done, cruise_on, cruise_integral
