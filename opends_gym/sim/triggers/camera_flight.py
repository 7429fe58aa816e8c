"""OpenDS's camera flight: a camera moving along scenario track points at a fixed speed.

Why: ConTRe-style tasks move the view along `driver/cameraFlight/track` and script events
with `cameraWaypoint:<id>` conditions, which fire when the camera reaches that point.
The flight runs in simulation time and only while the simulation is not paused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...task.model_scene import Point
from ...task.model_task import DrivingTask

Vec3 = tuple[float, float, float]


@dataclass
class FlightState:
    active: bool = False
    finished: bool = False
    distance_m: float = 0.0
    next_point: int = 0  # index of the next waypoint not yet reached


class CameraFlight:
    """Track points (with the ids their conditions use) and the flight's progress."""

    def __init__(self, task: DrivingTask) -> None:
        flight = task.scenario.driver.camera_flight
        points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}
        self.points: list[tuple[str, Vec3]] = []
        if flight is not None:
            for p in flight.track:
                pos = p.translation_m if p.translation_m is not None else points.get(p.ref)
                if pos is not None:
                    self.points.append((p.id or p.ref, pos))
        self.speed_mps = flight.speed_mps if flight else 0.0
        self.automatic_start = bool(flight and flight.automatic_start)
        self.automatic_stop = bool(flight and flight.automatic_stop)
        self.cumulative: list[float] = [0.0]
        for (_, a), (_, b) in zip(self.points, self.points[1:]):
            self.cumulative.append(self.cumulative[-1] + math.dist(a, b))
        self.state = FlightState()

    @property
    def defined(self) -> bool:
        return len(self.points) >= 2 and self.speed_mps > 0.0

    def reset(self) -> None:
        self.state = FlightState(active=self.defined and self.automatic_start)

    def start(self) -> None:
        if self.defined:
            self.state.active, self.state.finished = True, False

    def step(self, dt_s: float) -> list[str]:
        """Advance; returns the ids of waypoints reached in this step, in track order."""
        st = self.state
        if not st.active:
            return []
        if st.distance_m == 0.0 and st.next_point == 0:
            st.next_point = 1
            reached = [self.points[0][0]]
        else:
            reached = []
        st.distance_m += self.speed_mps * dt_s
        while st.next_point < len(self.points) and self.cumulative[st.next_point] <= st.distance_m + 1e-9:
            reached.append(self.points[st.next_point][0])
            st.next_point += 1
        if st.next_point >= len(self.points):
            st.distance_m = self.cumulative[-1]
            st.active, st.finished = False, True
        return reached

    def position(self) -> Vec3 | None:
        """Where the camera is now (None without a flight)."""
        if not self.defined:
            return None
        d = min(self.state.distance_m, self.cumulative[-1])
        for i in range(1, len(self.points)):
            if d <= self.cumulative[i] or i == len(self.points) - 1:
                a, b = self.points[i - 1][1], self.points[i][1]
                seg = self.cumulative[i] - self.cumulative[i - 1]
                f = 0.0 if seg <= 0 else min(1.0, (d - self.cumulative[i - 1]) / seg)
                return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))
        return self.points[0][1]
