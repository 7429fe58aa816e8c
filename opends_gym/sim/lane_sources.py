"""The ego's road from whatever a task gives: OpenDRIVE lanes, Gen B road segments, the
driver's autopilot waypoints, an ideal track or a traffic car's route.

Why: lateral offset, lane index, SDLP, "off the road" and the rule driver all need the
line the ego's lane follows (curves included) and where the other lanes lie across it.
OpenDS keeps that knowledge in several places depending on the task's version; this
module turns each into one `EgoRoad`: a reference line through the centre of the ego's
start lane, in its driving direction, plus the lane centres across it (+ left).

Sources, first that applies (OpenDS X-band `road/lane`s are handled by `guide.RoadGuide`
itself, they need no line):
1. OpenDRIVE (`openDrive` entry): the driver's start lane (`scenario/driver/openDrive`, or
   the lane under the start pose) followed along the network (`OpenDriveMap.route`); the
   lanes are the car lanes of the start cross-section.
2. Gen B road segments (`road/segments`): the segment the ego starts on or joins, followed
   through the network; its lanes are the declared `leftNeighbor`/`rightNeighbor`
   segments, else the segments running parallel to it (`segment_lanes`).
3. Gen A 4.x autopilot waypoints of the driver's car (`autoPilot/wayPoints`): the
   follow-box's Catmull-Rom path from the start waypoint. Lanes unknown.
4. The ideal track (`driver/idealTracks`). Lanes unknown.
5. A Gen A traffic car's waypoint path that passes within `JOIN_MAX_M` of the start in the
   ego's direction (the road traffic uses). Lanes unknown.

Where the ego starts off its road's line (the MotorwayTask ego starts on a slip road that
exists only in the scene's 3D model, 89 m from the motorway lane it joins), the line
begins with a cubic Hermite connector from the start pose to a point of the road ahead.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..task.model_task import DrivingTask, Pose
from ..task.values import Rotation
from .opendrive.route import CAR_LANE_TYPES
from .route_line import best_match, dedupe, heading_of, join_start, project
from .segment_lanes import DEFAULT_LANE_WIDTH_M, ROUTE_MAX_M, segment_road
from .traffic.paths import catmull_rom
from .traffic.routes import DEFAULT_TENSION, PositionResolver

if TYPE_CHECKING:
    from .road import RoadModel


@dataclass(frozen=True)
class EgoRoad:
    """The ego's road: a reference line (x, z), lanes across it (+ left) and its edges."""

    source: str  # opendrive | segments | autopilot | ideal_track | traffic_route
    points: np.ndarray  # (N, 2) world x, z along the driving direction
    lane_laterals_m: tuple[float, ...]  # lane centres across the line, rightmost first
    lane_ids: tuple[str, ...]
    lane_width_m: float
    lanes_known: bool
    left_edge_m: float  # the road's edges across the line (left > 0 > right)
    right_edge_m: float
    join_s_m: float = 0.0  # arc length where the connector from the start pose ends


# --------------------------------------------------------------------------- geometry


def _frame(
    source: str,
    points: np.ndarray,
    join_s: float,
    laterals: Sequence[float],
    ids: Sequence[str],
    width: float,
    known: bool,
    edges: tuple[float, float] | None = None,
) -> EgoRoad:
    order = sorted(range(len(laterals)), key=lambda i: laterals[i])
    lats = tuple(float(laterals[i]) for i in order)
    left, right = edges if edges is not None else (lats[-1] + width / 2.0, lats[0] - width / 2.0)
    return EgoRoad(source, points, lats, tuple(ids[i] for i in order), width, known, left, right, join_s)


# --------------------------------------------------------------------------- sources


def _from_opendrive(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    od = road.opendrive
    if od is None:
        return None
    spec = task.scenario.driver.open_drive
    where: tuple[str, int, float] | None
    if spec is not None and spec.start_road_id is not None and spec.start_lane is not None:
        where = (spec.start_road_id, int(spec.start_lane), spec.start_s_m or 0.0)
    else:
        where = od.locate(start.position_m[0], start.position_m[2], CAR_LANE_TYPES)
    if where is None:
        return None
    road_id, lane_id, s = where
    target = (spec.target_road_id, spec.target_lane, spec.target_s_m) if spec is not None else (None, None, None)
    prefs = spec.preferred_connections if spec is not None else ()
    try:
        pts = od.route(road_id, lane_id, s, target[0], target[1], target[2], prefs, max_length_m=ROUTE_MAX_M)
    except ValueError:
        return None
    if len(pts) < 2:
        return None
    joined = join_start(start, np.asarray(pts, dtype=float)[:, :2])
    if joined is None:
        return None
    r = od.road(road_id)
    sec = r.sections[od.section_index(r, s, lane_id)]
    edges = od.lane_edges(r, sec, np.array([s]))
    sign = -1.0 if lane_id < 0 else 1.0  # right lanes drive along +s: + t is their left
    t0 = 0.5 * float(edges[lane_id][0][0] + edges[lane_id][1][0])
    lats: list[float] = []
    ids: list[str] = []
    outer: list[float] = []
    for lid, (inner, outer_t) in edges.items():
        lane = sec.lanes[lid]
        if lane.type not in CAR_LANE_TYPES or abs(float(outer_t[0] - inner[0])) < 0.5:
            continue
        c = 0.5 * float(inner[0] + outer_t[0])
        lats.append(-sign * (c - t0))
        ids.append(str(lid))
        outer.extend((-sign * (float(inner[0]) - t0), -sign * (float(outer_t[0]) - t0)))
    width = abs(float(edges[lane_id][1][0] - edges[lane_id][0][0])) or DEFAULT_LANE_WIDTH_M
    return _frame("opendrive", joined[0], joined[1], lats, ids, width, True, (max(outer), min(outer)))


def _from_segments(task: DrivingTask, start: Pose) -> EgoRoad | None:
    found = segment_road(task, start)
    if found is None:
        return None
    points, join_s, lats, ids, width = found
    return _frame("segments", points, join_s, lats, ids, width, True)


def _single(source: str, start: Pose, line: np.ndarray, width: float = DEFAULT_LANE_WIDTH_M) -> EgoRoad | None:
    joined = join_start(start, line)
    if joined is None:
        return None
    return _frame(source, joined[0], joined[1], [0.0], ["0"], DEFAULT_LANE_WIDTH_M, False, (width, -width))


def _from_autopilot(task: DrivingTask, start: Pose) -> EgoRoad | None:
    ap = task.scenario.driver.car.auto_pilot
    if ap is None or len(ap.way_points) < 2:
        return None
    where = PositionResolver(task)
    xyz = [where(w) for w in ap.way_points]
    if any(p is None for p in xyz):
        return None
    ids = [w.id for w in ap.way_points]
    k = ids.index(ap.start_way_point) if ap.start_way_point in ids else 0
    ctrl = np.array(xyz, dtype=float)
    tension = ap.curve_tension if ap.curve_tension is not None else DEFAULT_TENSION
    pts, knots = catmull_rom(ctrl, tension, bool(ap.path_is_cycle))
    line = pts[knots[k] :, [0, 2]]
    if ap.path_is_cycle:  # go round once more from the start waypoint
        line = np.vstack([line, pts[1 : knots[k] + 1, [0, 2]]])
    line = dedupe(line)
    return _single("autopilot", start, line) if len(line) >= 2 else None


def _from_ideal_track(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    """The ideal track, continued on the traffic route that carries on from its end (the
    track is the analyzer's stretch, the road goes on)."""
    if not road.ideal_tracks:
        return None
    line, width = next(iter(road.ideal_tracks.values()))
    pts = dedupe(np.asarray(line.xz, dtype=float))
    if len(pts) < 2:
        return None
    end = Pose((float(pts[-1, 0]), 0.0, float(pts[-1, 1])), Rotation.from_euler_deg(0.0, math.degrees(heading_of(pts, len(pts) - 2)), 0.0))
    lines = _traffic_lines(task)
    found = best_match(end, lines)
    if found is not None and found[1] <= 10.0:
        _, _, k, _ = project(lines[found[0]], float(pts[-1, 0]), float(pts[-1, 1]))
        pts = dedupe(np.vstack([pts, lines[found[0]][k + 1 :]]))
    return _single("ideal_track", start, pts, max(width / 2.0, DEFAULT_LANE_WIDTH_M))


def _traffic_lines(task: DrivingTask) -> list[np.ndarray]:
    """The Gen A waypoint paths of the traffic cars, as (x, z) lines."""
    where = PositionResolver(task)
    lines = []
    for v in task.scenario.vehicles:
        wps = v.way_points
        if len(wps) < 2:
            continue
        xyz = [where(w) for w in wps]
        if any(p is None for p in xyz):
            continue
        tension = v.curve_tension if v.curve_tension is not None else DEFAULT_TENSION
        pts, _ = catmull_rom(np.array(xyz, dtype=float), tension, bool(v.path_is_cycle))
        line = dedupe(pts[:, [0, 2]])
        if len(line) >= 2:
            lines.append(line)
    return lines


def _from_traffic(task: DrivingTask, start: Pose) -> EgoRoad | None:
    lines = _traffic_lines(task)
    found = best_match(start, lines)
    return _single("traffic_route", start, lines[found[0]]) if found is not None else None


def ego_road(task: DrivingTask, road: RoadModel, start: Pose) -> EgoRoad | None:
    """The ego's road from the first source that applies (module docstring), or None."""
    return (
        _from_opendrive(task, road, start)
        or _from_segments(task, start)
        or _from_autopilot(task, start)
        or _from_ideal_track(task, road, start)
        or _from_traffic(task, start)
    )


def road_summary(task: DrivingTask) -> tuple[str, int]:
    """(where the ego's road comes from, the lanes known across it) as the envs measure lanes
    (`guide.RoadGuide`): X-band `lanes`, a source of this module, or none (0 lanes: a line
    to follow, lanes unknown). For `opends-gym validate`."""
    if task.scenario.road.lanes:
        return "lanes", len(task.scenario.road.lanes)
    from .road import RoadModel

    model = RoadModel(task)
    road = ego_road(task, model, model.driver_start_pose() or task.start_pose)
    if road is None:
        return "none", 0
    return road.source, len(road.lane_laterals_m) if road.lanes_known else 0
