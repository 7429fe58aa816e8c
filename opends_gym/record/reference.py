"""The reference line of an OpenDS drive log whose task defines no lanes and no ideal track.

Why: lateral offset, lane index and SDLP need a line to measure from. A carData.txt starts
where the car was when `startRecording` fired, often hundreds of metres from the task's
start pose, so that pose is no reference (it gave mean |lane offset| of 340 m on a real
Countryside drive). From the log's own first position we take, in order:

* the traffic route passing within `ROUTE_SNAP_M` of it -- a Gen A vehicle's own waypoint
  spline or a Gen B road segment, sampled as OpenDS's traffic follows them -- the nearest
  one, turned to run the way the car heads: the lane the car started in;
* else the straight line through the first position along the first heading.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from ..sim.road import Polyline
from ..task.model_task import DrivingTask
from ..task.model_traffic import TrafficVehicle

log = logging.getLogger(__name__)

ROUTE_SNAP_M = 3.5  # one lane width: a route this close to the first position is the car's lane


def route_polylines(task: DrivingTask) -> dict[str, np.ndarray]:
    """(x, z) samples of every traffic route of a task, by vehicle id (Gen A) or segment id (Gen B)."""
    from ..sim.traffic.paths import PathBank
    from ..sim.traffic.routes import PositionResolver, RoadNetwork, build_own_path

    bank = PathBank()
    where = PositionResolver(task)
    ids: dict[int, str] = {}  # path id -> route name
    for v in task.scenario.traffic:
        if isinstance(v, TrafficVehicle) and v.way_points:
            try:
                ids[build_own_path(v, bank, where).path] = f"vehicle {v.id}"
            except ValueError as e:
                log.debug("route of '%s' unusable: %s", v.id, e)
    try:
        ids.update({s.path: f"segment {s.id}" for s in RoadNetwork(task, bank, where).segments})
    except (ValueError, KeyError) as e:
        log.debug("road network unusable: %s", e)
    paths = bank.extra(0)
    return {name: paths[pid][:, [0, 2]] for pid, name in ids.items()}


def _start_line(x0: float, z0: float, yaw0: float) -> dict[str, Any]:
    return {
        "kind": "start_line",
        "start_xz": [x0, z0],
        "start_yaw": yaw0,
        "lane_laterals_m": [0.0],
        "lane_ids": ["0"],
        "lane_width_m": 3.5,
    }


def log_reference(
    x: np.ndarray, z: np.ndarray, yaw: np.ndarray, task: DrivingTask | None, ego_road: np.ndarray | None = None
) -> tuple[dict[str, Any], str]:
    """The guide dict (`locate_many`'s input) anchored at the log's first position, and a note
    saying which. Candidates: the task's ego road (`ego_road`, the route the envs follow) and
    its traffic routes, each only where the log's first position lies on it."""
    x0, z0, yaw0 = float(x[0]), float(z[0]), float(yaw[0])
    best: tuple[float, str, Polyline] | None = None
    candidates = dict(route_polylines(task)) if task is not None else {}
    if ego_road is not None:  # after the traffic routes: on a tie the route keeps its name
        candidates["the ego's road"] = ego_road
    for rid, pts in candidates.items():
        keep = np.concatenate([[True], np.hypot(np.diff(pts[:, 0]), np.diff(pts[:, 1])) > 1e-9])
        if int(keep.sum()) < 2:
            continue
        poly = Polyline([tuple(p) for p in pts[keep]])
        p = poly.project(x0, z0)
        if abs(p.offset_m) <= ROUTE_SNAP_M and (best is None or abs(p.offset_m) < best[0]):
            _, _, heading = poly.point_at(p.s_m)
            if math.cos(heading - yaw0) < 0.0:  # the car heads against the route: measure along its travel
                poly = Polyline([tuple(q) for q in poly.xz[::-1]])
            best = (abs(p.offset_m), rid, poly)
    if best is None:
        guide = _start_line(x0, z0, yaw0)
        return guide, "lateral position measured from the straight line through the log's first position and heading"
    guide = _start_line(x0, z0, yaw0)
    guide.update(kind="route", route=best[1], polyline=best[2].xz.tolist())
    what = best[1] if best[1] == "the ego's road" else f"the traffic route of {best[1]}"
    return guide, f"lateral position measured from {what} (nearest the log's first position)"
