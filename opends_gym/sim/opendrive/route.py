"""Routes along OpenDRIVE lanes: lane sections, road links and junction connections.

Why: OpenDS's OpenDRIVE cars (`ODvehicle`, the driver's autopilot) follow a lane from a
start (road, lane, s) to an optional target, taking preferred junction connections. The
walk is over "pieces" -- one lane of one lane section -- travelled in the lane's driving
direction (right-hand traffic: negative lane ids towards +s, positive towards -s).

Real files get road links wrong: init_drive's `s000` says its successor `s001` is joined
at its "end" although `s001` *starts* where `s000` ends. The declared contact point is
therefore checked against the geometry once at load; when the other end of the linked
road is the one that touches, it is used instead and a warning is logged.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Iterable
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from .parse import Junction, LaneSection, Road, RoadLink

log = logging.getLogger("opends_gym.opendrive")

# lane types a car may drive on (OpenDRIVE 1.5 `e_laneType`); others (border, sidewalk...) end a route
CAR_LANE_TYPES = frozenset({"driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp", "mwyEntry", "mwyExit", "bidirectional"})

Piece = tuple[str, int, int]  # (road id, lane-section index, lane id)
_CONTACT_TOL_M = 1.0
_BFS_LIMIT = 20_000


def connection_key(p: Any) -> tuple[str, str]:
    """(junction id, connection id) of an ODConnection-like object or a pair."""
    if isinstance(p, tuple | list):
        return (str(p[0]), str(p[1]))
    return (str(p.junction_id), str(p.connection_id))


class RoadGraph(Protocol):
    """What route planning reads of a map (`map.OpenDriveMap` is one): the roads and junctions
    by id, lane geometry, the file for messages, and the list that collects its warnings."""

    path: Path
    roads: dict[str, Road]
    junctions: dict[str, Junction]
    warnings: list[str]

    def road(self, road_id: str) -> Road: ...
    def check_s(self, road: Road, s: float) -> float: ...
    def section_index(self, road: Road, s: float, lane_id: int | None = None) -> int: ...
    def lane_points(self, road: Road, sec: LaneSection, lane_id: int, s: np.ndarray) -> np.ndarray: ...


class RoutePlanner:
    def __init__(self, od: RoadGraph) -> None:
        self.od = od
        self.contact: dict[tuple[str, str], str] = {}  # (road id, predecessor|successor) -> start|end
        for road in od.roads.values():
            for which in ("predecessor", "successor"):
                link = getattr(road, which)
                if link is not None and link.element_type == "road":
                    self.contact[(road.id, which)] = self._checked_contact(road, which, link)

    # ------------------------------------------------------------------ links
    def _end_point(self, road: Road, at_end: bool) -> tuple[float, float]:
        ref = road.reference.evaluate(road.length if at_end else 0.0)
        return float(ref.x[0]), float(ref.y[0])

    def _checked_contact(self, road: Road, which: str, link: RoadLink) -> str:
        other = self.od.roads[link.element_id]
        here = self._end_point(road, which == "successor")
        d = {cp: math.dist(here, self._end_point(other, cp == "end")) for cp in ("start", "end")}
        declared = link.contact_point
        best = min(d, key=lambda cp: d[cp])
        if declared is None or (d[declared] > _CONTACT_TOL_M and d[best] <= _CONTACT_TOL_M):
            if declared is not None:
                msg = (
                    f"{self.od.path.name}: road '{road.id}' {which} '{other.id}' declares contactPoint '{declared}', "
                    f"but the roads meet at its {best} ({d[declared]:.2f} m vs {d[best]:.2f} m); using '{best}'"
                )
                self.od.warnings.append(msg)
                log.warning("%s", msg)
            return best
        return declared

    def next_pieces(self, piece: Piece, lane_types: frozenset[str]) -> list[tuple[Piece, tuple[str, str] | None]]:
        """Where a car in `piece` can continue, in file order, with the junction connection used."""
        road_id, si, lane_id = piece
        road = self.od.roads[road_id]
        sec = road.sections[si]
        lane = sec.lanes[lane_id]
        forward = lane_id < 0
        out: list[tuple[Piece, tuple[str, str] | None]] = []

        def add(rid: str, sec_i: int, lid: int | None, key: tuple[str, str] | None, enter_at_start: bool) -> None:
            if lid is None or lid == 0 or (lid < 0) != enter_at_start:
                return  # no link, or a lane that would drive against its own direction
            s2 = self.od.roads[rid].sections[sec_i]
            if lid in s2.lanes and s2.lanes[lid].type in lane_types:
                out.append(((rid, sec_i, lid), key))

        link_lane = lane.successor if forward else lane.predecessor
        nxt = si + 1 if forward else si - 1
        if 0 <= nxt < len(road.sections):  # same road, next lane section (same id if no link)
            add(road_id, nxt, link_lane if link_lane is not None else lane_id, None, forward)
            return out
        which = "successor" if forward else "predecessor"
        link = getattr(road, which)
        if link is None:
            return out
        if link.element_type == "road":
            other = self.od.roads[link.element_id]
            at_start = self.contact[(road_id, which)] == "start"
            add(other.id, 0 if at_start else len(other.sections) - 1, link_lane, None, at_start)
            return out
        junction = self.od.junctions[link.element_id]
        for conn in junction.connections:
            if conn.incoming_road != road_id:
                continue
            other = self.od.roads[conn.connecting_road]
            at_start = conn.contact_point == "start"
            for frm, to in conn.lane_links:
                if frm == lane_id:
                    add(other.id, 0 if at_start else len(other.sections) - 1, to, (junction.id, conn.id), at_start)
        return out

    def _reaches(self, start: Piece, road_id: str, lane_id: int | None, lane_types: frozenset[str]) -> bool:
        seen = {start}
        queue = deque([start])
        while queue and len(seen) < _BFS_LIMIT:
            p = queue.popleft()
            if p[0] == road_id and (lane_id is None or p[2] == lane_id):
                return True
            for q, _ in self.next_pieces(p, lane_types):
                if q not in seen:
                    seen.add(q)
                    queue.append(q)
        return False

    def _choose(
        self,
        options: list[tuple[Piece, tuple[str, str] | None]],
        preferred: set[tuple[str, str]],
        target: tuple[str, int | None] | None,
        lane_types: frozenset[str],
    ) -> Piece:
        ranked = [p for p, key in options if key in preferred] + [p for p, key in options if key not in preferred]
        if target is not None:
            for lane in (target[1], None) if target[1] is not None else (None,):
                for p in ranked:
                    if self._reaches(p, target[0], lane, lane_types):
                        return p
        return ranked[0]

    # ------------------------------------------------------------------ walk
    def route(
        self,
        start_road_id: str,
        start_lane: int,
        start_s: float,
        target_road_id: str | None,
        target_lane: int | None,
        target_s: float | None,
        preferred_connections: Iterable[Any],
        lane_types: Iterable[str],
        max_length_m: float,
        step_m: float,
    ) -> np.ndarray:
        od = self.od
        types = frozenset(lane_types)
        road = od.road(start_road_id)
        s = od.check_s(road, start_s)
        lane_id = int(start_lane)
        si = od.section_index(road, s, lane_id)
        if lane_id == 0 or lane_id not in road.sections[si].lanes:
            raise ValueError(f"{od.path.name}: road '{road.id}' has no lane {lane_id} at s={s}")
        if target_road_id is not None:
            od.road(target_road_id)
        preferred = {connection_key(p) for p in preferred_connections}
        target = (str(target_road_id), target_lane) if target_road_id is not None else None
        step = max(float(step_m), 0.05)
        piece: Piece = (road.id, si, lane_id)
        chunks: list[np.ndarray] = []
        travelled = 0.0
        for _ in range(100_000):
            road = od.roads[piece[0]]
            sec = road.sections[piece[1]]
            forward = piece[2] < 0
            s_exit = sec.s1 if forward else sec.s0
            stop = False
            if target is not None and road.id == target[0] and target_s is not None:
                lo, hi = (s, s_exit) if forward else (s_exit, s)
                if lo - 1e-9 <= target_s <= hi + 1e-9:
                    s_exit, stop = float(target_s), True
            n = max(1, math.ceil(abs(s_exit - s) / step))
            chunks.append(od.lane_points(road, sec, piece[2], np.linspace(s, s_exit, n + 1)))
            travelled += abs(s_exit - s)
            if stop or travelled >= max_length_m:
                break
            options = self.next_pieces(piece, types)
            if not options:
                break
            if target is not None and target_s is None and road.id == target[0] and all(p[0] != road.id for p, _ in options):
                break  # the end of the target road
            piece = self._choose(options, preferred, target, types)
            nsec = od.roads[piece[0]].sections[piece[1]]
            s = nsec.s0 if piece[2] < 0 else nsec.s1
        pts = np.concatenate(chunks)
        keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-6])
        return pts[keep]
