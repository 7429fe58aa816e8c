"""Small synthetic tasks for the traffic tests: ConTRe's scene with the traffic and roads a test needs."""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path
from typing import Any

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task
from opends_gym.task.model_interaction import Interaction
from opends_gym.task.model_road import Road, RoadWayPoint, RoadWayPoints, Segment, Segments
from opends_gym.task.model_task import Pose
from opends_gym.task.model_traffic import TrafficVehicle, VehicleWayPoint
from opends_gym.task.values import Rotation

from .conftest import CORPUS

FAR = (3000.0, 0.0, 3000.0)  # where the ego car waits when a test does not need it
KMH = 1.0 / 3.6


@functools.cache
def base_task() -> DrivingTask:
    return load_task(CORPUS / "opends-cts" / "ConTReTask")


def small_task(traffic: tuple = (), road: Road | None = None) -> DrivingTask:
    """A small task (ConTRe's scene, no triggers) with the given traffic and road network."""
    b = base_task()
    return replace(b, scenario=replace(b.scenario, traffic=tuple(traffic), road=road or Road()), interaction=Interaction())


def world_for(task: DrivingTask | Path, seed: int = 0, ego_at: tuple[float, float, float] | None = FAR, yaw_deg: float = 0.0) -> World:
    w = World(task if isinstance(task, DrivingTask) else load_task(task), WorldConfig(), seed=seed)
    if ego_at is not None:
        w.reset(seed, start=Pose(ego_at, Rotation.from_euler_deg(0.0, yaw_deg, 0.0)))
    return w


def gen_a_car(
    vid: str, points: list[tuple[float, float]], kmh: list[float], cyclic: bool = False, extra: dict[int, dict[str, Any]] | None = None
) -> TrafficVehicle:
    """A Gen A car on its own waypoints (x, z); `extra` maps a waypoint index to more fields."""
    wps = tuple(
        VehicleWayPoint(id=f"{vid}_wp{k}", translation_m=(x, 0.0, z), speed_mps=v * KMH, **(extra or {}).get(k, {}))
        for k, ((x, z), v) in enumerate(zip(points, kmh))
    )
    return TrafficVehicle(
        id=vid, max_distance_from_path_m=5.0, curve_tension=0.05, path_is_cycle=cyclic, start_way_point=wps[0].id, way_points=wps
    )


def straight_car(vid: str, x: float = 0.0, kmh: float = 50.0, extra: dict[int, dict[str, Any]] | None = None) -> TrafficVehicle:
    length = 1000.0
    n = 11
    return gen_a_car(vid, [(x, -length * k / (n - 1)) for k in range(n)], [kmh] * n, extra=extra)


def road_wp(wid: str, x: float, z: float, **kw) -> RoadWayPoint:
    return RoadWayPoint(id=wid, translation_m=(x, 0.0, z), **kw)


def segment(sid: str, a: str, b: str, kmh: float = 50.0, **kw) -> Segment:
    return Segment(id=sid, from_wp=a, to_wp=b, speed_mps=kmh * KMH, **kw)


def network(wps: list[RoadWayPoint], segs: list[Segment], **kw) -> Road:
    return Road(way_points=RoadWayPoints(points=tuple(wps)), segments=Segments(items=tuple(segs)), **kw)


def run_for(w: World, seconds: float, controls: DriverControls | None = None) -> None:
    for _ in range(int(round(seconds / w.dt_s))):
        w.step(controls)
