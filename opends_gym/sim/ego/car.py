"""The driver's car: controls -> powertrain -> physics backend, plus OpenDS's car features.

Why: cruise control (with `initialSpeed`), the engine block's `minSpeed` floor, the
max-speed cap, engine on/off, hand brake, manual/automatic gears, crosswind and resets are
OpenDS car behaviour every env and the human mode share.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ...task.model_task import DrivingTask, Pose
from ..controls import DriverControls
from .fast_body import FastVehicle
from .kernels import CRUISE_GAIN, CRUISE_INTEGRAL_BAND_MPS, CRUISE_INTEGRAL_MAX, CRUISE_KI, car_constants
from .powertrain import Powertrain, gear_rpm
from .spec import MAX_WHEEL_ANGLE_RAD, BodyState, VehicleBackend, VehicleSpec
from .step import A_MIN_SPEED, cruise_params, drive_inputs, ego_step, ego_steps

__all__ = ["CRUISE_GAIN", "CRUISE_INTEGRAL_BAND_MPS", "CRUISE_INTEGRAL_MAX", "CRUISE_KI", "CarInputs", "EgoCar", "make_backend"]
_NO_LEAD = (float("nan"), float("nan"))


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
        cc = car.cruise_control
        self._aid = cruise_params(car.engine.min_speed_mps, cc.suppress_deactivation_by_brake, cc.acc, cc.emergency_brake_distance_m,
                                  cc.safety_distance_forward_m)  # fmt: skip
        self._car = None  # the fast backend's and powertrain's constants for `ego_step`
        if isinstance(backend, FastVehicle):
            self._car = car_constants(backend._params, *self.powertrain._tables)
        self._initial_powertrain = _copy_powertrain_state(self.powertrain)
        self.inputs = CarInputs()
        self.cruise_active = False
        self.cruise_target_mps = 0.0
        self.cruise_integral = 0.0
        self.crosswind = (0.0, 0.0)  # (steering offset, seconds left)
        self.lead: tuple[float, float] | None = None  # (gap m, lead speed m/s) for ACC, set by the world

    @property
    def min_speed_mps(self) -> float:
        """The engine block's minSpeed (m/s; 0: none)."""
        return float(self._aid[A_MIN_SPEED])

    @min_speed_mps.setter
    def min_speed_mps(self, value: float) -> None:
        self._aid[A_MIN_SPEED] = value

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

    def reset_to(self, x: float, y: float, z: float, yaw: float, speed_mps: float, engine_on: bool = True) -> None:
        """Put the car in a given moving state (a recorded one): pose, forward speed, and the
        gear the automatic would hold at that speed with its rpm; cruise control off."""
        self.body.reset(x, y, z, yaw, speed_mps)
        pt = self.powertrain
        st = pt.state
        st.engine_on = engine_on
        if st.automatic and st.gear > 0:
            st.gear = pt.best_gear(speed_mps)
        ratio = pt.reverse_ratio if st.gear < 0 else pt.ratios[st.gear - 1] if st.gear > 0 else 0.0
        rpm = min(gear_rpm(speed_mps, ratio), self.car.engine.max_rpm)
        st.rpm = max(rpm, self.car.engine.min_rpm) if engine_on else rpm
        st.prev_v_mps = speed_mps
        self.inputs = CarInputs()
        self.cruise_active = False
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
        if c.engine_on is not None or c.toggle_automatic or c.gear is not None or c.shift_up or c.shift_down:
            self._gearbox(c)
        if c.cruise_control is not None or c.cruise_speed_delta_mps:
            self._cruise_command(c)
        body = self.body
        s = body.state
        steer = c.steering
        offset, left = self.crosswind
        if left > 0.0:
            steer = max(-1.0, min(1.0, steer + offset))
            self.crosswind = (offset, left - dt_s)
        st = self.powertrain.state
        lead_gap, lead_v = self.lead if self.lead is not None else _NO_LEAD
        if physics_on and self._car is not None:
            # the fast backend: driver's aids, powertrain and body in one compiled call
            steer_rad = steer * MAX_WHEEL_ANGLE_RAD
            s.steer_rad = steer_rad
            slope = body.ground_pitch  # type: ignore[attr-defined]
            s.pitch = slope(s.x, s.z, s.yaw) if slope is not None else 0.0
            s.x, s.z, s.yaw, s.u, s.v, s.r, free, gas, brake, self.cruise_active, self.cruise_integral = ego_step(
                self._car, self._aid, st.values, st.ring, dt_s, steer_rad, c.accelerator, c.brake, c.clutch, c.hand_brake,
                self.cruise_active, self.cruise_target_mps, self.cruise_integral, lead_gap, lead_v, s.x, s.z, s.yaw, s.u, s.v, s.r,
                s.pitch,
            )  # fmt: skip
            if free < 2:
                st.ensure_ring_room()
            ground = body.ground_height  # type: ignore[attr-defined]
            if ground is not None:
                s.y = ground(s.x, s.z)
        else:
            v = s.u
            gas, brake, self.cruise_active, self.cruise_integral = drive_inputs(
                self._aid, st.values, v, c.accelerator, c.brake, dt_s, self.cruise_active, self.cruise_target_mps, self.cruise_integral,
                lead_gap, lead_v,
            )  # fmt: skip
            if physics_on:  # a backend of its own (bullet)
                drive, brake_force = self.powertrain.forces(dt_s, v, gas * (1.0 - c.clutch), brake, s.pitch, c.hand_brake)
                body.step(dt_s, steer * MAX_WHEEL_ANGLE_RAD, drive, brake_force)
        self.inputs = CarInputs(steer, gas, brake, c.clutch, c.hand_brake, c.turn_signal or self.inputs.turn_signal, c.horn)

    def _gearbox(self, c: DriverControls) -> None:
        """Engine switch, automatic toggle and gear requests."""
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

    def _cruise_command(self, c: DriverControls) -> None:
        """Cruise control on (at the current speed) or off, and set-speed changes. The
        controller itself (PI on the speed, ACC) is `ego.kernels.cruise_control`."""
        if c.cruise_control is True:
            self.cruise_active, self.cruise_target_mps = True, max(self.body.state.u, 0.0)
            self.cruise_integral = 0.0
        elif c.cruise_control is False:
            self.cruise_active = False
        if c.cruise_speed_delta_mps:
            self.cruise_target_mps = max(0.0, self.cruise_target_mps + c.cruise_speed_delta_mps)

    def ahead(self, dt_s: float, c: DriverControls, steps: int) -> tuple[float, float, float]:
        """(x, z, forward speed) after `steps` physics steps holding the clipped inputs `c`; the car is
        put back as it was (a look ahead through the car model: `data.recovery` searches inputs with it)."""
        state = self.get_state()
        try:
            if self._car is None or self.crosswind[1] > 0.0 or c.engine_on is not None or c.gear is not None:
                for _ in range(steps):  # the general path (another backend, crosswind, gear changes)
                    self.step(dt_s, c)
                s = self.body.state
                return float(s.x), float(s.z), float(s.u)
            s = self.body.state
            st = self.powertrain.state
            x, z, yaw, u, v, r, pitch = s.x, s.z, s.yaw, s.u, s.v, s.r, 0.0
            on, integral = self.cruise_active, self.cruise_integral
            lead_gap, lead_v = self.lead if self.lead is not None else _NO_LEAD
            slope = self.body.ground_pitch  # type: ignore[attr-defined]
            steer_rad = c.steering * MAX_WHEEL_ANGLE_RAD
            left = steps
            while left > 0:  # `step`'s fast path without its bookkeeping, compiled where the road's slope is constant
                n = left if slope is None else 1
                if slope is not None:
                    pitch = slope(x, z, yaw)
                x, z, yaw, u, v, r, done, on, integral = ego_steps(
                    self._car, self._aid, st.values, st.ring, dt_s, steer_rad, c.accelerator, c.brake, c.clutch, c.hand_brake, on,
                    self.cruise_target_mps, integral, lead_gap, lead_v, x, z, yaw, u, v, r, pitch, n,
                )  # fmt: skip
                left -= done
                st.ensure_ring_room()
            return float(x), float(z), float(u)
        finally:
            self.set_state(state)

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
        return FastVehicle(spec, options.get("ground_height"), options.get("ground_pitch"))
    if kind == "bullet":
        from ...extras import require

        require("bullet", "pybullet")  # physics="bullet" without pybullet: one line naming the extra
        from ..bullet.vehicle import BulletVehicle

        return BulletVehicle(spec, task, **options)
    raise ValueError(f"unknown physics backend '{kind}' (use 'fast' or 'bullet')")
