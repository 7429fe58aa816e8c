"""A reference line for "where should the car be": lanes, the ego's road or the start heading.

Why: observations (heading error, lateral offset), discrete meta-actions, SDLP, "off the
road" and the rule driver all need one answer to "how far am I from my lane centre and
how is the road heading", whatever the task gives: OpenDS X-band lanes (lane tasks run
along Z), the ego's road from `lane_sources` (OpenDRIVE lanes, Gen B segments and their
neighbours, the autopilot's waypoints, an ideal track, a traffic route; curves included),
or nothing but the start pose. Lateral coordinates are positive to the left of travel.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from .lane_sources import ego_road
from .road import Polyline
from .world import World

DEFAULT_LANE_WIDTH_M = 3.5
_WALK_MAX = 64  # segments walked from the last answer on a route before giving up
_SURE_M = 2.5  # a walked answer farther than this from the line is checked against the whole route


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
        start = getattr(world, "start_pose", None) or task.start_pose
        self.start_xz = (start.position_m[0], start.position_m[2])
        self.start_yaw = start.yaw_rad
        lanes = world.road.lanes
        self.kind: str
        self.source: str
        self.polyline: Polyline | None = None
        self.lanes_known = False
        self.join_s_m = 0.0  # on a route: where the connector from the start pose ends
        if lanes:
            self.kind = self.source = "lanes"
            # X-band lanes: the road runs along -Z (yaw 0) or +Z (yaw pi)
            self.sign = 1.0 if math.cos(self.start_yaw) >= 0.0 else -1.0
            self.road_heading = 0.0 if self.sign > 0 else math.pi
            # lanes keep the road model's order (by world X, like OpenDS's lane ids)
            self.lane_laterals_m = tuple(-self.sign * b.center for b in lanes)
            self.lane_ids = tuple(b.id for b in lanes)
            self.lane_width_m = sum(b.x_max - b.x_min for b in lanes) / len(lanes)
            edges = [-self.sign * v for b in lanes for v in (b.x_min, b.x_max)]
            self.road_edges_m = (max(edges), min(edges))
            self.lanes_known = True
        else:
            road = ego_road(task, world.road, start) if hasattr(task, "scenario") else None
            if road is not None:
                self.kind = "route"
                self.source = road.source
                self.polyline = Polyline([(float(x), float(z)) for x, z in road.points])
                self.lane_laterals_m = road.lane_laterals_m
                self.lane_ids = road.lane_ids
                self.lane_width_m = road.lane_width_m
                self.road_edges_m = (road.left_edge_m, road.right_edge_m)
                self.lanes_known = road.lanes_known
                self.join_s_m = road.join_s_m
                self._route_tables()
            else:
                self.kind = self.source = "start_line"
                self.lane_laterals_m = (0.0,)
                self.lane_ids = ("0",)
                self.lane_width_m = DEFAULT_LANE_WIDTH_M
                self.road_edges_m = (math.inf, -math.inf)  # no road known: never off it
        self._last: tuple[float, float, GuidePoint] = (math.nan, math.nan, GuidePoint(0.0, 0.0, 0.0, -1))
        self._hint = 0
        # the start line's forward and left directions (the same floats `locate` computes)
        self._start_axes = (-math.sin(self.start_yaw), -math.cos(self.start_yaw), -math.cos(self.start_yaw), math.sin(self.start_yaw))

    def _route_tables(self) -> None:
        """Per segment of the route: start, direction, length, arc length and heading, as
        plain floats for the windowed search."""
        assert self.polyline is not None
        xz, s = self.polyline.xz, self.polyline.s
        self._seg: list[tuple[float, float, float, float, float, float, float]] = []
        for k in range(len(xz) - 1):
            ax, az = float(xz[k, 0]), float(xz[k, 1])
            dx, dz = float(xz[k + 1, 0]) - ax, float(xz[k + 1, 1]) - az
            L = math.hypot(dx, dz) or 1e-9
            self._seg.append((ax, az, dx, dz, L, float(s[k]), math.atan2(-dx, -dz)))
        self._hint = 0

    def reset(self) -> None:
        """Forget the route position of the last episode (the windowed search starts anew)."""
        self._hint = 0
        self._last = (math.nan, math.nan, GuidePoint(0.0, 0.0, 0.0, -1))

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
        if self.kind == "route":
            s, lat, heading = self._route_foot(x, z)
            return GuidePoint(s, lat, heading, self._lane_index(lat))
        s, lat = self._along_start_line(x, z)
        return GuidePoint(s, lat, self.start_yaw, 0 if abs(lat) < self.lane_width_m / 2 else -1)

    def _route_foot(self, x: float, z: float) -> tuple[float, float, float]:
        """(s, lateral, heading) of the foot point on the route: walked from the last answer
        segment by segment (a step moves the car a metre or so); an answer off the line is
        checked against the whole route (the walk finds the nearest point near the last one,
        a point far from it may be nearer another part of the route)."""
        seg = self._seg
        n = len(seg)
        k = self._hint
        t = 0.0
        for _ in range(_WALK_MAX):
            ax, az, dx, dz, L, _, _ = seg[k]
            t = ((x - ax) * dx + (z - az) * dz) / (L * L)
            if t > 1.0 and k + 1 < n:
                bx, bz, ex, ez, M, _, _ = seg[k + 1]
                if ((x - bx) * ex + (z - bz) * ez) < 0.0:  # outside a corner: its vertex
                    t = 1.0
                    break
                k += 1
            elif t < 0.0 and k > 0:
                bx, bz, ex, ez, M, _, _ = seg[k - 1]
                if ((x - bx) * ex + (z - bz) * ez) > M * M:
                    t = 0.0
                    break
                k -= 1
            else:
                break
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
        ax, az, dx, dz, L, s0, heading = seg[k]
        px, pz = ax + t * dx, az + t * dz
        ex, ez = x - px, z - pz
        d2 = ex * ex + ez * ez
        for j in (k - 1, k + 1):  # inside a bend two segments hold a foot point: the nearer one
            if 0 <= j < n:
                bx, bz, fx, fz, M, _, _ = seg[j]
                u = ((x - bx) * fx + (z - bz) * fz) / (M * M)
                u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
                gx, gz = x - bx - u * fx, z - bz - u * fz
                if gx * gx + gz * gz < d2 - 1e-12:
                    k, t, d2, ex, ez = j, u, gx * gx + gz * gz, gx, gz
                    ax, az, dx, dz, L, s0, heading = seg[k]
        if d2 > _SURE_M * _SURE_M:  # off the line: the whole route may hold a nearer point (numpy)
            assert self.polyline is not None
            q = self.polyline.project(x, z)
            if q.offset_m * q.offset_m < d2 - 1e-12:
                self._hint = q.segment
                return q.s_m, q.offset_m, seg[q.segment][6]
        self._hint = k
        return s0 + t * L, (ex * dz - ez * dx) / L, heading  # left of travel (dx, dz) is (dz, -dx)

    def heading_at(self, s_m: float) -> float:
        """The reference heading at arc length s (the start heading off a route)."""
        if self.kind == "route" and self.polyline is not None:
            return self.polyline.point_at(s_m)[2]
        return self.road_heading if self.kind == "lanes" else self.start_yaw

    def point_at(self, s_m: float) -> tuple[float, float, float]:
        """(x, z, heading) of the reference line (lateral 0) at arc length s: the road ahead for
        a preview (a route clamps s to its ends; lanes and the start line run on straight)."""
        if self.kind == "route" and self.polyline is not None:
            return self.polyline.point_at(s_m)
        if self.kind == "lanes":  # lateral = -sign * x, s = -sign * (z - start z)
            return 0.0, self.start_xz[1] - self.sign * s_m, self.road_heading
        fx, fz, _, _ = self._start_axes
        return self.start_xz[0] + s_m * fx, self.start_xz[1] + s_m * fz, self.start_yaw

    def lanes_known_at(self, s_m: float) -> bool:
        """Whether the lanes at arc length s are the task's (not on the start connector)."""
        return self.lanes_known and s_m >= self.join_s_m

    def route_length_m(self) -> float:
        """How far the route goes (infinite where the road is a straight line)."""
        return self.polyline.length if self.kind == "route" and self.polyline is not None else math.inf

    def off_road(self, lateral_m: float) -> bool:
        """Beyond the road's edges (lanes known: the outer lane edges; a route without lanes:
        one lane width either side of it; no road known: never)."""
        left, right = self.road_edges_m
        return lateral_m > left or lateral_m < right

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
        elif self.kind == "route":  # (no GuidePoint: this runs every physics step)
            s, lat, _ = self._route_foot(x, z)
            lane = self._lane_index(lat)
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
