"""A reference line for "where should the car be": lanes, ideal track or start heading.

Why: observations (heading error, lateral offset), discrete meta-actions and the rule
driver all need one answer to "how far am I from my lane centre and how is the road
heading", whatever the task gives: OpenDS X-band lanes (lane tasks run along Z), an ideal
track, or nothing but the start pose. Lateral coordinates are positive to the left of
travel.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from .road import Polyline
from .world import World

DEFAULT_LANE_WIDTH_M = 3.5


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class GuidePoint(NamedTuple):
    """Where a point lies along the reference (a named tuple: asked several times a step)."""

    s_m: float  # distance along the reference
    lateral_m: float  # position across it, + left
    heading_rad: float  # reference heading (world yaw convention)
    lane_index: int  # index into `lane_laterals_m`, -1 off the lanes


class RoadGuide:
    """Reference line of a World, chosen once at construction."""

    def __init__(self, world: World) -> None:
        self.world = world
        task = world.task
        start = task.start_pose
        self.start_xz = (start.position_m[0], start.position_m[2])
        self.start_yaw = start.yaw_rad
        lanes = world.road.lanes
        self.kind: str
        self.polyline: Polyline | None = None
        if lanes:
            self.kind = "lanes"
            # X-band lanes: the road runs along -Z (yaw 0) or +Z (yaw pi)
            self.sign = 1.0 if math.cos(self.start_yaw) >= 0.0 else -1.0
            self.road_heading = 0.0 if self.sign > 0 else math.pi
            # lanes keep the road model's order (by world X, like OpenDS's lane ids)
            self.lane_laterals_m = tuple(-self.sign * b.center for b in lanes)
            self.lane_ids = tuple(b.id for b in lanes)
            self.lane_width_m = sum(b.x_max - b.x_min for b in lanes) / len(lanes)
        elif world.road.ideal_tracks:
            self.kind = "ideal_track"
            self.polyline = next(iter(world.road.ideal_tracks.values()))[0]
            self.lane_laterals_m = (0.0,)
            self.lane_ids = ("0",)
            self.lane_width_m = DEFAULT_LANE_WIDTH_M
        else:
            self.kind = "start_line"
            self.lane_laterals_m = (0.0,)
            self.lane_ids = ("0",)
            self.lane_width_m = DEFAULT_LANE_WIDTH_M
        self._last: tuple[float, float, GuidePoint] = (math.nan, math.nan, GuidePoint(0.0, 0.0, 0.0, -1))
        # the start line's forward and left directions (the same floats `locate` computes)
        self._start_axes = (-math.sin(self.start_yaw), -math.cos(self.start_yaw), -math.cos(self.start_yaw), math.sin(self.start_yaw))

    def locate(self, x: float, z: float) -> GuidePoint:
        """Where (x, z) lies (the last answer is kept: a step asks it several times for the
        same car position, the same float objects)."""
        last = self._last
        if last[0] is x and last[1] is z:
            return last[2]
        p = self._locate(x, z)
        self._last = (x, z, p)
        return p

    def _locate(self, x: float, z: float) -> GuidePoint:
        if self.kind == "lanes":
            lat = -self.sign * x
            s = -self.sign * (z - self.start_xz[1])
            return GuidePoint(s, lat, self.road_heading, self._lane_index(lat))
        if self.kind == "ideal_track" and self.polyline is not None:
            p = self.polyline.project(x, z)
            _, _, heading = self.polyline.point_at(p.s_m)
            return GuidePoint(p.s_m, p.offset_m, heading, 0 if abs(p.offset_m) < self.lane_width_m / 2 else -1)
        s, lat = self._along_start_line(x, z)
        return GuidePoint(s, lat, self.start_yaw, 0 if abs(lat) < self.lane_width_m / 2 else -1)

    def _along_start_line(self, x: float, z: float) -> tuple[float, float]:
        """(distance along, lateral position across) the line through the start position along
        the start heading."""
        fx, fz, lx, lz = self._start_axes
        dx, dz = x - self.start_xz[0], z - self.start_xz[1]
        return dx * fx + dz * fz, dx * lx + dz * lz

    def lane_position(self, x: float, z: float) -> tuple[float, float, int, float]:
        """(s, lateral, lane index, offset from the centre of that lane, or of the nearest lane
        when off the lanes): `locate` plus the lane offset, without building a GuidePoint (the
        env's trace asks this every physics step)."""
        if self.kind == "lanes":
            lat = -self.sign * x
            s = -self.sign * (z - self.start_xz[1])
            half = self.lane_width_m / 2.0
            for i, c in enumerate(self.lane_laterals_m):  # (`_lane_index`, inlined: this runs every physics step)
                if abs(lat - c) <= half:
                    return s, lat, i, lat - c
            lane = -1
        elif self.kind == "start_line":  # (no GuidePoint; its one lane is centred on the line)
            s, lat = self._along_start_line(x, z)
            return s, lat, 0 if abs(lat) < self.lane_width_m / 2 else -1, lat - self.lane_laterals_m[0]
        else:
            p = self.locate(x, z)
            s, lat, lane = p.s_m, p.lateral_m, p.lane_index
        centre = self.lane_laterals_m[lane if lane >= 0 else self.nearest_lane(lat)]
        return s, lat, lane, lat - centre

    def _lane_index(self, lat: float) -> int:
        half = self.lane_width_m / 2.0
        for i, c in enumerate(self.lane_laterals_m):
            if abs(lat - c) <= half:
                return i
        return -1

    def nearest_lane(self, lat: float) -> int:
        """The lane whose centre is nearest (the first of equals)."""
        centres = self.lane_laterals_m
        best, best_d = 0, abs(centres[0] - lat)
        for i in range(1, len(centres)):
            d = abs(centres[i] - lat)
            if d < best_d:
                best, best_d = i, d
        return best
