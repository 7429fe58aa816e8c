"""scenario.xml: weather, the driver (car, ideal tracks, camera flight), traffic and road."""

from __future__ import annotations

from dataclasses import dataclass

from .bind import BOOL, FLOAT, INT, KMH, STR, Struct, attr, elem, elems, source_line
from .model_car import Car
from .model_road import CoordinateConversion, FrictionItem, Road
from .model_traffic import TRAFFIC_ITEMS, ODConnection, ODVehicle, Pedestrian, TrafficObject, TrafficVehicle
from .values import VEC3, Vec3


@dataclass(frozen=True)
class Weather:
    """Percentages 0..100; -1 means the effect is off."""

    snowing_percent: float = elem("snowingPercentage", FLOAT, -1.0)
    raining_percent: float = elem("rainingPercentage", FLOAT, -1.0)
    fog_percent: float = elem("fogPercentage", FLOAT, -1.0)


@dataclass(frozen=True)
class Environment:
    weather: Weather = elem("weather", Struct(Weather), Weather())
    use_bloom_filter: bool | None = elem("useBloomFilter", BOOL)
    use_shadow_filter: bool | None = elem("useShadowFilter", BOOL)


@dataclass(frozen=True)
class TrackPoint:
    """A point of an ideal track or camera flight: inline translation or `ref` to a scene point."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    translation_m: Vec3 | None = elem("translation", VEC3)
    line: int = source_line()


@dataclass(frozen=True)
class IdealTrack:
    """The normative path the Drive Analyzer measures mean deviation against."""

    id: str = attr("id", STR, "")
    road_width_m: float = attr("roadWidth", FLOAT, 15.0)
    points: tuple[TrackPoint, ...] = elems(".", ("point", Struct(TrackPoint)))
    line: int = source_line()


@dataclass(frozen=True)
class CameraFlight:
    speed_mps: float = elem("speed", KMH, 50.0 / 3.6, keep=True)
    automatic_start: bool = elem("automaticStart", BOOL, False)
    automatic_stop: bool = elem("automaticStop", BOOL, False)
    track: tuple[TrackPoint, ...] = elems("track", ("point", Struct(TrackPoint)))


@dataclass(frozen=True)
class DriverOpenDrive:
    """2023: start/target of the ego car on the OpenDRIVE road network."""

    auto_pilot: bool = elem("autoPilot", BOOL, False)
    preferred_connections: tuple[ODConnection, ...] = elems("preferredConnections", ("ODconnection", Struct(ODConnection)))
    start_road_id: str | None = elem("startRoadID", STR)
    start_lane: int | None = elem("startLane", INT)
    start_s_m: float | None = elem("startS", FLOAT)
    target_road_id: str | None = elem("targetRoadID", STR)
    target_lane: int | None = elem("targetLane", INT)
    target_s_m: float | None = elem("targetS", FLOAT)
    visualize_follow_box: bool | None = elem("visualizeFollowBox", BOOL)
    distance_to_follow_box_m: float | None = elem("distanceToFollowBox", FLOAT)


@dataclass(frozen=True)
class Driver:
    camera_flight: CameraFlight | None = elem("cameraFlight", Struct(CameraFlight))
    ideal_tracks: tuple[IdealTrack, ...] = elems("idealTracks", ("idealTrack", Struct(IdealTrack)))
    car: Car = elem("car", Struct(Car), required=True)
    open_drive: DriverOpenDrive | None = elem("openDrive", Struct(DriverOpenDrive))


@dataclass(frozen=True)
class Scenario:
    environment: Environment = elem("environment", Struct(Environment), Environment())
    driver: Driver = elem("driver", Struct(Driver), required=True)
    traffic: tuple[TrafficObject, ...] = elems("traffic", TRAFFIC_ITEMS)
    road: Road = elem("road", Struct(Road), Road())
    friction_map: tuple[FrictionItem, ...] = elems("frictionMap", ("frictionItem", Struct(FrictionItem)))
    coordinate_conversion: CoordinateConversion | None = elem("coordinateConversion", Struct(CoordinateConversion))

    @property
    def vehicles(self) -> tuple[TrafficVehicle, ...]:
        return tuple(t for t in self.traffic if isinstance(t, TrafficVehicle))

    @property
    def pedestrians(self) -> tuple[Pedestrian, ...]:
        return tuple(t for t in self.traffic if isinstance(t, Pedestrian))

    @property
    def od_vehicles(self) -> tuple[ODVehicle, ...]:
        return tuple(t for t in self.traffic if isinstance(t, ODVehicle))

    def ideal_track(self, track_id: str) -> IdealTrack | None:
        return next((t for t in self.driver.ideal_tracks if t.id == track_id), None)
