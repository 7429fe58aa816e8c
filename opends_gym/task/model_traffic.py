"""scenario.xml `traffic`: cars and pedestrians in both schema generations.

Why: Gen A (OpenDS up to 4.5) gives each vehicle its own waypoint list with a speed per
waypoint; Gen B (2018+) lets vehicles roam a shared road network of segments; 2023 adds
OpenDRIVE lane followers. One model holds all three so the traffic manager can drive any.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .bind import BOOL, FLOAT, INT, KMH, MS, REF_ITEM, STR, Choice, Node, Struct, attr, elem, elems, source_line
from .values import ROTATION, VEC3, Rotation, Vec3

TURN_SIGNALS = ("off", "left", "right", "both")


@dataclass(frozen=True)
class VehicleWayPoint:
    """Gen A waypoint of one vehicle's own path: a position (or `ref` to a scene point) and a speed."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    translation_m: Vec3 | None = elem("translation", VEC3)
    speed_mps: float | None = elem("speed", KMH)
    traffic_light: str | None = elem("trafficLight", STR)
    head_light_intensity: float | None = elem("headLightIntensity", FLOAT)
    turn_signal: str | None = elem("turnSignal", Choice(*TURN_SIGNALS))
    brake_light_on: bool | None = elem("brakeLightOn", BOOL)
    waiting_time_s: float | None = elem("waitingTime", MS)
    line: int = source_line()


@dataclass(frozen=True)
class ODConnection:
    junction_id: str = attr("junctionID", STR, "")
    connection_id: str = attr("connectionID", STR, "")


@dataclass(frozen=True)
class TrafficVehicle:
    """A traffic car following its waypoints (Gen A) or the segment network (Gen B)."""

    id: str = attr("id", required=True)
    model_path: str = elem("modelPath", STR, "")
    mass_kg: float = elem("mass", FLOAT, 800.0, keep=True)
    acceleration_mps2: float = elem("acceleration", FLOAT, 3.3, keep=True)
    deceleration_brake_mps2: float = elem("decelerationBrake", FLOAT, 8.7, keep=True)
    deceleration_free_wheel_mps2: float = elem("decelerationFreeWheel", FLOAT, 2.0, keep=True)
    engine_on: bool = elem("engineOn", BOOL, True, keep=True)
    reset_when_stuck: bool | None = elem("resetWhenStuck", BOOL)
    min_distance_from_path_m: float | None = elem("minDistanceFromPath", FLOAT)
    max_distance_from_path_m: float | None = elem("maxDistanceFromPath", FLOAT)
    max_speed_mps: float | None = elem("maxSpeed", KMH)
    give_way_distance_m: float | None = elem("giveWayDistance", FLOAT)
    intersection_observation_distance_m: float | None = elem("intersectionObservationDistance", FLOAT)
    min_intersection_clearance_m: float | None = elem("minIntersectionClearance", FLOAT)
    never_faster_than_steering_car: bool | None = elem("neverFasterThanSteeringCar", BOOL)
    curve_tension: float | None = elem("curveTension", FLOAT)
    path_is_cycle: bool | None = elem("pathIsCycle", BOOL)
    path_is_visible: bool | None = elem("pathIsVisible", BOOL)
    start_way_point: str | None = elem("startWayPoint", STR)
    way_points: tuple[VehicleWayPoint, ...] = elems("wayPoints", ("wayPoint", Struct(VehicleWayPoint)))
    segment_refs: tuple[str, ...] = elems("segments", ("segment", REF_ITEM))
    line: int = source_line()

    @property
    def uses_road_network(self) -> bool:
        return not self.way_points


@dataclass(frozen=True)
class Pedestrian:
    """A walking person on its own waypoints (Gen A) or on road segments (Gen B)."""

    id: str = attr("id", required=True)
    model_path: str = elem("modelPath", STR, "")
    enabled: bool = elem("enabled", BOOL, True)
    reset_when_stuck: bool | None = elem("resetWhenStuck", BOOL)
    mass_kg: float = elem("mass", FLOAT, 80.0, keep=True)
    animation_stand: str | None = elem("animationStand", STR)
    animation_walk: str | None = elem("animationWalk", STR)
    scale: float | None = elem("scale", FLOAT)
    local_translation_m: Vec3 | None = elem("localTranslation", VEC3)
    local_rotation: Rotation | None = elem("localRotation", ROTATION)
    min_distance_from_path_m: float | None = elem("minDistanceFromPath", FLOAT)
    max_distance_from_path_m: float | None = elem("maxDistanceFromPath", FLOAT)
    max_speed_mps: float | None = elem("maxSpeed", KMH)
    give_way_distance_m: float | None = elem("giveWayDistance", FLOAT)
    intersection_observation_distance_m: float | None = elem("intersectionObservationDistance", FLOAT)
    min_intersection_clearance_m: float | None = elem("minIntersectionClearance", FLOAT)
    curve_tension: float | None = elem("curveTension", FLOAT)
    path_is_cycle: bool | None = elem("pathIsCycle", BOOL)
    path_is_visible: bool | None = elem("pathIsVisible", BOOL)
    start_way_point: str | None = elem("startWayPoint", STR)
    way_points: tuple[VehicleWayPoint, ...] = elems("wayPoints", ("wayPoint", Struct(VehicleWayPoint)))
    segment_refs: tuple[str, ...] = elems("segments", ("segment", REF_ITEM))
    line: int = source_line()

    @property
    def uses_road_network(self) -> bool:
        return not self.way_points


@dataclass(frozen=True)
class ODVehicle:
    """2023: a car following OpenDRIVE lanes from a start to an optional target position."""

    id: str = attr("id", required=True)
    model_path: str = elem("modelPath", STR, "")
    mass_kg: float = elem("mass", FLOAT, 800.0, keep=True)
    acceleration_mps2: float = elem("acceleration", FLOAT, 3.3, keep=True)
    deceleration_brake_mps2: float = elem("decelerationBrake", FLOAT, 8.7, keep=True)
    deceleration_free_wheel_mps2: float = elem("decelerationFreeWheel", FLOAT, 2.0, keep=True)
    engine_on: bool = elem("engineOn", BOOL, True, keep=True)
    distance_from_path_m: float | None = elem("distanceFromPath", FLOAT)
    visualize_follow_box: bool | None = elem("visualizeFollowBox", BOOL)
    max_speed_mps: float | None = elem("maxSpeed", KMH)
    never_faster_than_steering_car: bool | None = elem("neverFasterThanSteeringCar", BOOL)
    start_road_id: str = elem("startRoadID", STR, required=True)
    start_lane: int = elem("startLane", INT, required=True)
    start_s_m: float = elem("startS", FLOAT, 0.0)
    target_road_id: str | None = elem("targetRoadID", STR)
    target_lane: int | None = elem("targetLane", INT)
    target_s_m: float | None = elem("targetS", FLOAT)
    preferred_connections: tuple[ODConnection, ...] = elems("preferredConnections", ("ODconnection", Struct(ODConnection)))
    line: int = source_line()


TrafficObject = TrafficVehicle | Pedestrian | ODVehicle

TRAFFIC_ITEMS: dict[str, Node[Any]] = {
    "vehicle": Struct(TrafficVehicle),
    "pedestrian": Struct(Pedestrian),
    "ODvehicle": Struct(ODVehicle),
}
