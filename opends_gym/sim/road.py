"""Where the car is on the road: lane bands, lateral offset, speed limits, ideal tracks.

Why: reaction timers, observations and metrics all ask "which lane, how far off its
centre, what limit applies, how far along the ideal track". OpenDS answers lanes with
`road/lane` X-bands (the car is in a lane when 0.75 m inside both edges); ideal tracks are
polylines of points. OpenDRIVE roads, where a task has one, answer through `opendrive`.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..task.model_scene import Point
from ..task.model_task import DrivingTask, Pose
from .opendrive.map import OpenDriveMap, driver_start_pose

LANE_MARGIN_M = 0.75  # OpenDS: inside a lane when this far inside both of its edges


@dataclass(frozen=True)
class LaneBand:
    id: str
    x_min: float
    x_max: float

    @property
    def center(self) -> float:
        return 0.5 * (self.x_min + self.x_max)


@dataclass(frozen=True)
class TrackProjection:
    """A point's relation to a polyline: distance along it and signed offset (+ left)."""

    s_m: float
    offset_m: float
    segment: int


class Polyline:
    """A 2D path in (x, z) with arc length, for ideal tracks and lane centre lines."""

    def __init__(self, points: list[tuple[float, float]]) -> None:
        if len(points) < 2:
            raise ValueError("a polyline needs at least two points")
        self.xz = np.asarray(points, dtype=float)
        d = np.diff(self.xz, axis=0)
        self.seg_len = np.hypot(d[:, 0], d[:, 1])
        self.s = np.concatenate([[0.0], np.cumsum(self.seg_len)])
        self.length = float(self.s[-1])

    def project(self, x: float, z: float) -> TrackProjection:
        """Closest point on the polyline; offset is positive to the left of travel."""
        a = self.xz[:-1]
        d = self.xz[1:] - a
        L2 = np.maximum(self.seg_len**2, 1e-12)
        t = np.clip(((x - a[:, 0]) * d[:, 0] + (z - a[:, 1]) * d[:, 1]) / L2, 0.0, 1.0)
        px = a[:, 0] + t * d[:, 0]
        pz = a[:, 1] + t * d[:, 1]
        dist2 = (px - x) ** 2 + (pz - z) ** 2
        k = int(np.argmin(dist2))
        dx, dz = d[k]
        seg_len = self.seg_len[k] or 1.0
        # left of travel direction (dx, dz) in our frame is (dz, -dx) (forward -Z, left -X)
        lx, lz = dz / seg_len, -dx / seg_len
        offset = (x - px[k]) * lx + (z - pz[k]) * lz
        return TrackProjection(float(self.s[k] + t[k] * self.seg_len[k]), float(offset), k)

    def point_at(self, s_m: float) -> tuple[float, float, float]:
        """(x, z, heading yaw) at arc length s (clamped to the ends)."""
        s_m = min(max(s_m, 0.0), self.length)
        k = min(int(np.searchsorted(self.s, s_m, side="right")) - 1, len(self.seg_len) - 1)
        f = (s_m - self.s[k]) / (self.seg_len[k] or 1.0)
        x0, z0 = self.xz[k]
        x1, z1 = self.xz[k + 1]
        yaw = math.atan2(-(x1 - x0), -(z1 - z0))
        return (float(x0 + f * (x1 - x0)), float(z0 + f * (z1 - z0)), yaw)


class RoadModel:
    """The road facts a task gives: lane bands, ideal tracks, speed limits."""

    def __init__(self, task: DrivingTask) -> None:
        road = task.scenario.road
        bands = sorted((LaneBand(lane.id, lane.x_min_m, lane.x_max_m) for lane in road.lanes), key=lambda b: b.x_min)
        self.lanes: tuple[LaneBand, ...] = tuple(bands)
        self.lane_ids = tuple(b.id for b in bands)
        self._edges = [b.x_min for b in bands]
        points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}
        self.ideal_tracks: dict[str, tuple[Polyline, float]] = {}
        for i, track in enumerate(task.scenario.driver.ideal_tracks):
            pts = []
            for p in track.points:
                pos = p.translation_m if p.translation_m is not None else points.get(p.ref)
                if pos is not None:
                    pts.append((pos[0], pos[2]))
            if len(pts) >= 2:
                self.ideal_tracks[track.id or f"idealTrack{i}"] = (Polyline(pts), track.road_width_m)
        self.current_limit_mps = 0.0
        self.upcoming_limit_mps = 0.0
        self._task = task
        path = task.open_drive_path  # a missing file is a load warning already; then there is no map
        self.opendrive: OpenDriveMap | None = OpenDriveMap.load(path) if path is not None and path.is_file() else None
        # (road id, lane id, s) of a world point; None (no OpenDRIVE) makes openDrivePos triggers warn once
        self.road_position: Callable[[float, float], tuple[str, int, float] | None] | None = (
            self.opendrive.locate if self.opendrive is not None else None
        )

    def driver_start_pose(self) -> Pose | None:
        """The ego's start on the OpenDRIVE network (scenario driver/openDrive), if the task gives one."""
        return driver_start_pose(self._task, self.opendrive)

    # ------------------------------------------------------------------ lanes
    def band_index(self, x: float) -> int:
        """Index (0 = smallest X) of the band containing x, or -1 off the lanes."""
        if not self.lanes:
            return -1
        i = bisect.bisect_right(self._edges, x) - 1
        if i < 0 or x > self.lanes[i].x_max:
            return -1
        return i

    def lane_id_at(self, x: float, margin_m: float = LANE_MARGIN_M) -> str | None:
        """OpenDS's lane test: the lane whose band holds x with `margin_m` to both edges."""
        for b in self.lanes:
            if b.x_min + margin_m <= x <= b.x_max - margin_m:
                return b.id
        return None

    def lateral_offset_m(self, x: float, yaw: float = 0.0) -> float:
        """Offset from the centre of the nearest lane band, positive to the driver's left.

        Lane bands are ranges of world X, so "left" depends on the travel direction: facing
        -Z (yaw 0, as in OpenDS's lane tasks) left is -X.
        """
        if not self.lanes:
            return 0.0
        i = self.band_index(x)
        if i < 0:
            i = 0 if x < self.lanes[0].x_min else len(self.lanes) - 1
        d = x - self.lanes[i].center
        return -d if math.cos(yaw) >= 0.0 else d

    # ------------------------------------------------------------------ limits
    def get_state(self) -> tuple[float, float]:
        return (self.current_limit_mps, self.upcoming_limit_mps)

    def set_state(self, state: tuple[float, float]) -> None:
        self.current_limit_mps, self.upcoming_limit_mps = state

    def reset(self) -> None:
        self.current_limit_mps = 0.0
        self.upcoming_limit_mps = 0.0
