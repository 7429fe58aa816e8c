"""The driver's car: controls -> powertrain -> physics backend, plus OpenDS's car features.

Why: cruise control (with `initialSpeed`), the engine block's `minSpeed` floor, the
max-speed cap, engine on/off, hand brake, manual/automatic gears, crosswind and resets are
OpenDS car behaviour every env and the human mode share.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..task.model_task import DrivingTask, Pose
from .controls import DriverControls
from .physics_fast import FastVehicle
from .powertrain import Powertrain
from .vehicle import MAX_WHEEL_ANGLE_RAD, BodyState, VehicleBackend, VehicleSpec

CRUISE_GAIN = 0.5  # throttle (or brake) per m/s of speed error
CRUISE_KI = 0.3  # throttle per (m/s x s): the integral holds the set speed against drag
CRUISE_INTEGRAL_BAND_MPS = 2.0  # integrate only this close to the set speed (no wind-up)
CRUISE_INTEGRAL_MAX = 0.8


@dataclass
class CarInputs:
    """What the car last applied (after cruise control and minSpeed), for timers and logs."""

    steering: float = 0.0
    accelerator: float = 0.0
    brake: float = 0.0
    clutch: float = 0.0
    hand_brake: bool = False
    turn_signal: str = "off"
    horn: bool = False


class EgoCar:
    """The ego vehicle of a World."""

    def __init__(self, task: DrivingTask, backend: VehicleBackend) -> None:
        car = task.scenario.driver.car
        self.car = car
        self.body = backend
        self.spec: VehicleSpec = backend.spec
        self.powertrain = Powertrain(car, self.spec.mass_kg)
        self._initial_powertrain = _copy_powertrain_state(self.powertrain)
        self.min_speed_mps = car.engine.min_speed_mps
        self.inputs = CarInputs()
        self.cruise_active = False
        self.cruise_target_mps = 0.0
        self.cruise_integral = 0.0
        self.crosswind = (0.0, 0.0)  # (steering offset, seconds left)
        self.lead: tuple[float, float] | None = None  # (gap m, lead speed m/s) for ACC, set by the world

    @property
    def state(self) -> BodyState:
        return self.body.state

    @property
    def speed_mps(self) -> float:
        return self.body.state.u

    # ------------------------------------------------------------------ lifecycle
    def reset(self, pose: Pose) -> None:
        x, y, z = pose.position_m
        cc = self.car.cruise_control
        speed = cc.initial_speed_mps
        self.body.reset(x, y, z, pose.yaw_rad, speed)
        self.powertrain.state = _copy_powertrain_state_from(self._initial_powertrain)
        self.powertrain.state.prev_v_mps = speed
        self.inputs = CarInputs()
        self.cruise_active = speed > 0.0
        self.cruise_target_mps = speed
        self.cruise_integral = 0.0
        self.crosswind = (0.0, 0.0)

    def teleport(self, pose: Pose) -> None:
        """Reset to a reset point: new pose, at rest (OpenDS's resetCar)."""
        x, y, z = pose.position_m
        self.body.reset(x, y, z, pose.yaw_rad, 0.0)
        self.powertrain.state.prev_v_mps = 0.0
        self.cruise_active = False

    def set_crosswind(self, direction: str, force: float, duration_s: float) -> None:
        """OpenDS adds crosswind to the steering input; right is negative."""
        offset = force if direction == "left" else -force
        self.crosswind = (offset, duration_s)

    # ------------------------------------------------------------------ step
    def step(self, dt_s: float, c: DriverControls, physics_on: bool = True) -> None:
        pt = self.powertrain
        st = pt.state
        if c.engine_on is not None:
            st.engine_on = c.engine_on
        if c.toggle_automatic:
            st.automatic = not st.automatic
        if c.gear is not None:
            pt.shift(c.gear)
        elif not st.automatic:
            if c.shift_up:
                pt.shift(st.gear + 1)
            if c.shift_down:
                pt.shift(st.gear - 1)
        elif st.gear <= 0 and c.shift_up:
            pt.shift(1)
        gas, brake = c.accelerator, c.brake
        v = self.body.state.u
        # cruise control and ACC (nothing to do while it is off and not asked for)
        if self.cruise_active or c.cruise_control is not None or c.cruise_speed_delta_mps:
            gas, brake = self._cruise(c, v, gas, brake, dt_s)
        # the engine block's minSpeed: OpenDS keeps the car at least this fast off the brake
        if self.min_speed_mps > 0.0 and brake == 0.0 and st.gear > 0 and v < self.min_speed_mps:
            gas = max(gas, min(1.0, CRUISE_GAIN * (self.min_speed_mps - v) + 0.3))
        steer = c.steering
        offset, left = self.crosswind
        if left > 0.0:
            steer = max(-1.0, min(1.0, steer + offset))
            self.crosswind = (offset, left - dt_s)
        self.inputs = CarInputs(steer, gas, brake, c.clutch, c.hand_brake, c.turn_signal or self.inputs.turn_signal, c.horn)
        if not physics_on:
            return
        drive, brake_force = pt.forces(dt_s, v, gas * (1.0 - c.clutch), brake, 0.0, c.hand_brake)
        self.body.step(dt_s, steer * MAX_WHEEL_ANGLE_RAD, drive, brake_force)

    def _cruise(self, c: DriverControls, v: float, gas: float, brake: float, dt_s: float) -> tuple[float, float]:
        """Cruise control and ACC: (gas, brake) after a PI speed controller."""
        cc = self.car.cruise_control
        if c.cruise_control is True:
            self.cruise_active, self.cruise_target_mps = True, max(v, 0.0)
            self.cruise_integral = 0.0
        elif c.cruise_control is False:
            self.cruise_active = False
        if c.cruise_speed_delta_mps:
            self.cruise_target_mps = max(0.0, self.cruise_target_mps + c.cruise_speed_delta_mps)
        if self.cruise_active and brake > 0.0 and not cc.suppress_deactivation_by_brake:
            self.cruise_active = False
        if self.cruise_active:
            target = self.cruise_target_mps
            if cc.acc and self.lead is not None:
                gap, lead_v = self.lead
                if cc.emergency_brake_distance_m is not None and gap < cc.emergency_brake_distance_m:
                    target = 0.0
                elif gap < (cc.safety_distance_forward_m or 0.5 * v * 3.6):
                    target = min(target, lead_v)
            err = target - v
            if -CRUISE_INTEGRAL_BAND_MPS < err < CRUISE_INTEGRAL_BAND_MPS:
                self.cruise_integral = min(CRUISE_INTEGRAL_MAX, max(0.0, self.cruise_integral + CRUISE_KI * err * dt_s))
            throttle = CRUISE_GAIN * err + self.cruise_integral
            gas = max(gas, min(1.0, throttle)) if throttle > 0 else gas
            if err < -1.0:
                brake = max(brake, min(1.0, -CRUISE_GAIN * (err + 1.0) * 0.5))
        return gas, brake

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        return {
            "body": self.body.get_state(),
            "powertrain": _copy_powertrain_state(self.powertrain),
            "inputs": CarInputs(**self.inputs.__dict__),
            "cruise": (self.cruise_active, self.cruise_target_mps, self.cruise_integral),
            "crosswind": self.crosswind,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.body.set_state(state["body"])
        self.powertrain.state = _copy_powertrain_state_from(state["powertrain"])
        self.inputs = CarInputs(**state["inputs"].__dict__)
        self.cruise_active, self.cruise_target_mps, self.cruise_integral = state["cruise"]
        self.crosswind = state["crosswind"]


def _copy_powertrain_state(pt: Powertrain) -> Any:
    return _copy_powertrain_state_from(pt.state)


def _copy_powertrain_state_from(st: Any) -> Any:
    import copy

    return copy.deepcopy(st)


def make_backend(kind: str, task: DrivingTask, **options: Any) -> VehicleBackend:
    """The ego car's physics backend: `fast` (default) or `bullet`."""
    mass = task.car_model.mass_kg
    spec = VehicleSpec.from_car(task.scenario.driver.car, mass)
    if kind == "fast":
        return FastVehicle(spec, options.get("ground_height"))
    if kind == "bullet":
        from .physics_bullet import BulletVehicle

        return BulletVehicle(spec, task, **options)
    raise ValueError(f"unknown physics backend '{kind}' (use 'fast' or 'bullet')")
