"""The ego cars of a native batch: controls -> cruise/minSpeed -> powertrain -> single-track body.

Why: this is `sim.ego.EgoCar.step` + `sim.powertrain.Powertrain.step` +
`sim.ego.fast_body.FastVehicle.step` for N cars, one numpy array per state variable. A
compiled loop over the cars calls the single env's own kernels (`sim.ego.kernels`), so the
results are the same floats by construction. Only what the three batched tasks use is modelled: automatic gearbox, cruise control without
ACC, the engine's minSpeed, no crosswind, clutch, hand brake, slope or manual shifting
(`EgoParams.from_world` refuses a car that needs more).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..jit import inline, kernel, python_buffers, whole_batch
from ..sim.ego.kernels import body_step_wheels, cruise_control, min_speed_gas, powertrain_core, wheel_constants
from ..sim.ego.spec import MAX_WHEEL_ANGLE_RAD


@dataclass(frozen=True)
class EgoParams:
    """Constants of the car, read from a single env's World so they are the same floats."""

    car: np.ndarray  # the single env's car constants (`ego.kernels.car_constants`)
    mass: float
    lf: float
    lr: float
    wheelbase: float
    yaw_inertia: float
    half_track: float
    friction_slip: float
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
            car=ego._car,
            mass=spec.mass_kg,
            lf=spec.cog_to_front_m,
            lr=spec.wheelbase_m - spec.cog_to_front_m,
            wheelbase=spec.wheelbase_m,
            yaw_inertia=spec.yaw_inertia,
            half_track=0.5 * spec.track_m,
            friction_slip=spec.friction_slip,
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


def step(p: EgoParams, s: EgoArrays, dt: float, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray, live: np.ndarray) -> None:
    """One physics step of the rows `live` of `s`, in place."""
    _step_rows(
        p.car,
        p.engine_on,
        p.suppress_cruise_off,
        p.min_speed,
        dt,
        live,
        s.x,
        s.z,
        s.yaw,
        s.u,
        s.v,
        s.r,
        s.gear,
        s.rpm,
        s.prev_v,
        s.fuel_used,
        s.fuel_left,
        s.steer_in,
        s.gas_in,
        s.brake_in,
        s.cruise_on,
        s.cruise_target,
        s.cruise_int,
        np.ascontiguousarray(steer, dtype=np.float64),
        np.ascontiguousarray(gas, dtype=np.float64),
        np.ascontiguousarray(brake, dtype=np.float64),
    )


@whole_batch
@python_buffers
@kernel
def _step_rows(car: np.ndarray, engine_on: bool, suppress_cruise_off: bool, min_speed: float, dt: float, live: np.ndarray, x: np.ndarray,
               z: np.ndarray, yaw: np.ndarray, u: np.ndarray, v: np.ndarray, r: np.ndarray, gear: np.ndarray, rpm: np.ndarray,
               prev_v: np.ndarray, fuel_used: np.ndarray, fuel_left: np.ndarray, steer_in: np.ndarray, gas_in: np.ndarray,
               brake_in: np.ndarray, cruise_on: np.ndarray, cruise_target: np.ndarray, cruise_int: np.ndarray, steer: np.ndarray,
               gas: np.ndarray, brake: np.ndarray) -> None:  # fmt: skip
    """`ego_step` for the rows `live`, in place."""
    for e in range(len(u)):
        if live[e]:
            v0, steer_in[e] = u[e], steer[e]
            a = steer[e] * MAX_WHEEL_ANGLE_RAD
            x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e], fuel_used[e], fuel_left[e], cruise_on[e], cruise_int[e], gas_in[e], \
                brake_in[e], _, _ = ego_step(car, engine_on, suppress_cruise_off, min_speed, dt, x[e], z[e], yaw[e], u[e], v[e], r[e],
                                             gear[e], rpm[e], prev_v[e], fuel_used[e], fuel_left[e], cruise_on[e], cruise_target[e],
                                             cruise_int[e], a, math.cos(a), math.sin(a), gas[e], brake[e])  # fmt: skip
            prev_v[e] = v0


@inline
def ego_step(car: np.ndarray, engine_on: bool, suppress_cruise_off: bool, min_speed: float, dt: float, x: float, z: float, yaw: float,
             u: float, v: float, r: float, gear: int, rpm: float, prev_v: float, fuel_used: float, fuel_left: float, cruise_on: bool,
             cruise_target: float, cruise_int: float, steer_rad: float, cos_steer: float, sin_steer: float, gas: float,
             brake: float) -> tuple[float, ...]:  # fmt: skip
    """`EgoCar.step` of one car with the single env's own kernels: cruise control (no ACC),
    minSpeed, powertrain and body (`body_step_trig`: the steering angle's cosine and sine are
    given). Returns the new (x, z, yaw, u, v, r, gear, rpm, fuel used, fuel left, cruise on,
    cruise integral), the pedals applied (gas, brake) and the new heading's sine and cosine;
    the caller keeps the u it passed as the next step's `prev_v`, and the steering as applied."""
    wc = wheel_constants(car, dt, cos_steer, sin_steer)
    return ego_step_wheels(car, wc, engine_on, suppress_cruise_off, min_speed, dt, x, z, yaw, u, v, r, gear, rpm, prev_v, fuel_used,
                           fuel_left, cruise_on, cruise_target, cruise_int, cos_steer, sin_steer, gas, brake)  # fmt: skip


@inline
def ego_step_wheels(car: np.ndarray, wc: tuple[float, ...], engine_on: bool, suppress_cruise_off: bool, min_speed: float, dt: float,
                    x: float, z: float, yaw: float, u: float, v: float, r: float, gear: int, rpm: float, prev_v: float, fuel_used: float,
                    fuel_left: float, cruise_on: bool, cruise_target: float, cruise_int: float, cos_steer: float, sin_steer: float,
                    gas: float, brake: float) -> tuple[float, ...]:  # fmt: skip
    """`ego_step` given the car's `wheel_constants` at this steering (a caller that holds the
    steering for a policy step's physics steps computes them once)."""
    nan = math.nan
    g, b, cruise_on, cruise_int = cruise_control(
        cruise_on, cruise_target, cruise_int, u, gas, brake, dt, suppress_cruise_off, False, nan, 0.0, nan, nan
    )
    g = min_speed_gas(g, b, u, gear, min_speed)
    gear, rpm, drive, brake_n, _, _, _, fuel_used, fuel_left = powertrain_core(
        car, gear, True, engine_on, rpm, prev_v, fuel_used, fuel_left, dt, u, g * 1.0, b, 0.0, False
    )
    x, z, yaw, u, v, r, sy, cy = body_step_wheels(car, wc, x, z, yaw, u, v, r, dt, cos_steer, sin_steer, drive, brake_n, 0.0)
    return x, z, yaw, u, v, r, gear, rpm, fuel_used, fuel_left, cruise_on, cruise_int, g, b, sy, cy
