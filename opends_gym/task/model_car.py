"""scenario.xml `driver/car`: the ego car's engine, gearbox, brakes, suspension, fuel.

Why: the powertrain and both physics backends read their parameters from here. Defaults
are OpenDS's own (OpenDS `Car`, `SteeringCar`; docs/opends-compatibility.md#vehicle-model), so a task that omits a block drives like OpenDS.
"""

from __future__ import annotations

from dataclasses import dataclass

from .bind import BOOL, CM3, FLOAT, INT, KMH, REF_ITEM, STR, Struct, attr, elem, elems, source_line
from .model_traffic import VehicleWayPoint
from .values import FLOATS, ROTATION, VEC3, Rotation, Vec3

DEFAULT_FORWARD_RATIOS = (3.615, 1.955, 1.281, 0.973, 0.778, 0.646)


@dataclass(frozen=True)
class Tires:
    type: str | None = elem("type", STR)
    size_in: int | None = elem("size", INT)
    profile: str | None = attr("profile", STR)


@dataclass(frozen=True)
class Engine:
    engine_on: bool = elem("engineOn", BOOL, True)
    min_speed_mps: float = elem("minSpeed", KMH, 0.0)
    max_speed_mps: float = elem("maxSpeed", KMH, 130.0 / 3.6)
    acceleration_mps2: float = elem("acceleration", FLOAT, 3.3)
    displacement_m3: float = elem("displacement", CM3, 1800e-6)
    min_rpm: float = elem("minRPM", FLOAT, 750.0)
    max_rpm: float = elem("maxRPM", FLOAT, 7500.0)
    sound_intensity: float | None = elem("soundIntensity", FLOAT)
    profile: str | None = attr("profile", STR)


@dataclass(frozen=True)
class AutoPilot:
    """The ego car driven by the follow-box controller: along its own inline `wayPoints`
    (Gen A 4.x, read by OpenDS's `ScenarioLoader.getAutoPilotFollowBoxSettings`, with
    `curveTension`, `pathIsCycle`, `pathIsVisible`) or along road segments (Gen B).
    `startWayPoint` names one of the inline waypoints when there are any, else a road one."""

    enabled: bool = elem("enabled", BOOL, False)
    min_distance_from_path_m: float | None = elem("minDistanceFromPath", FLOAT)
    max_distance_from_path_m: float | None = elem("maxDistanceFromPath", FLOAT)
    max_speed_mps: float | None = elem("maxSpeed", KMH)
    give_way_distance_m: float | None = elem("giveWayDistance", FLOAT)
    intersection_observation_distance_m: float | None = elem("intersectionObservationDistance", FLOAT)
    min_intersection_clearance_m: float | None = elem("minIntersectionClearance", FLOAT)
    reset_when_stuck: bool | None = elem("resetWhenStuck", BOOL)
    start_way_point: str | None = elem("startWayPoint", STR)
    segment_refs: tuple[str, ...] = elems("segments", ("segment", REF_ITEM))
    curve_tension: float | None = elem("curveTension", FLOAT)
    path_is_cycle: bool | None = elem("pathIsCycle", BOOL)
    path_is_visible: bool | None = elem("pathIsVisible", BOOL)
    way_points: tuple[VehicleWayPoint, ...] = elems("wayPoints", ("wayPoint", Struct(VehicleWayPoint)))


@dataclass(frozen=True)
class CruiseControl:
    acc: bool = elem("acc", BOOL, False)
    safety_distance_lateral_m: float | None = elem("safetyDistance/lateral", FLOAT)
    safety_distance_forward_m: float | None = elem("safetyDistance/forward", FLOAT)
    emergency_brake_distance_m: float | None = elem("emergencyBrakeDistance", FLOAT)
    suppress_deactivation_by_brake: bool = elem("suppressDeactivationByBrake", BOOL, False)
    initial_speed_mps: float = elem("initialSpeed", KMH, 0.0)


@dataclass(frozen=True)
class Transmission:
    automatic: bool = elem("automatic", BOOL, True)
    reverse_ratio: float = elem("reverse", FLOAT, 3.182)
    forward_ratios: tuple[float, ...] = elem("forward", FLOATS, DEFAULT_FORWARD_RATIOS)


@dataclass(frozen=True)
class Suspension:
    stiffness: float = elem("stiffness", FLOAT, 120.0)
    compression: float = elem("compression", FLOAT, 0.2)
    damping: float = elem("damping", FLOAT, 0.3)


@dataclass(frozen=True)
class Wheel:
    friction_slip: float = elem("frictionSlip", FLOAT, 50.0)


@dataclass(frozen=True)
class Brake:
    deceleration_free_wheel_mps2: float = elem("decelerationFreeWheel", FLOAT, 0.4)
    deceleration_brake_mps2: float = elem("decelerationBrake", FLOAT, 8.7, keep=True)
    profile: str | None = attr("profile", STR)


@dataclass(frozen=True)
class Fuel:
    max_amount_l: float = elem("maxAmount", FLOAT, 60.0)
    initial_amount_l: float | None = elem("initialAmount", FLOAT)

    @property
    def start_l(self) -> float:
        return self.max_amount_l if self.initial_amount_l is None else self.initial_amount_l


@dataclass(frozen=True)
class CarLight:
    intensity: float | None = elem("intensity", FLOAT)


@dataclass(frozen=True)
class CarResetPoint:
    """A reset point of the car: a `ref` to a scene reset point, or an inline pose."""

    ref: str = attr("ref", STR, "")
    id: str = attr("id", STR, "")
    translation_m: Vec3 | None = elem("translation", VEC3)
    rotation: Rotation | None = elem("rotation", ROTATION)
    line: int = source_line()


@dataclass(frozen=True)
class Car:
    """The driver's car; `ref` names the scene model that gives its asset, mass and pose."""

    ref: str = attr("ref", STR, required=True)
    id: str = attr("id", STR, "")
    profile: str = attr("profile", STR, "")
    reset_points: tuple[CarResetPoint, ...] = elems("resetPoints", ("resetPoint", Struct(CarResetPoint)))
    tires: Tires = elem("tires", Struct(Tires), Tires())
    engine: Engine = elem("engine", Struct(Engine), Engine(), keep=True)
    auto_pilot: AutoPilot | None = elem("autoPilot", Struct(AutoPilot))
    cruise_control: CruiseControl = elem("cruiseControl", Struct(CruiseControl), CruiseControl())
    transmission: Transmission = elem("transmission", Struct(Transmission), Transmission())
    suspension: Suspension = elem("suspension", Struct(Suspension), Suspension())
    wheel: Wheel = elem("wheel", Struct(Wheel), Wheel())
    brake: Brake = elem("brake", Struct(Brake), Brake())
    fuel: Fuel = elem("fuel", Struct(Fuel), Fuel())
    light: CarLight | None = elem("light", Struct(CarLight))
    line: int = source_line()
