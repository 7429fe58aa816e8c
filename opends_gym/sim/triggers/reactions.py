"""Reaction timers with OpenDS's semantics, measured in simulation time.

Why: the reaction measurements are what make a driving task an experiment. OpenDS
(`eu.opends.reactionCenter`) polls its timers once per rendered frame with the wall
clock; here they are polled once per physics step with the simulation clock, so a
reaction time is exact to the physics step and repeatable.

Result codes: 1 correct, -1 failure, -2 missed (logged with 10 s, OpenDS's 10000 ms).
A correct reaction's time is `now - start - hold`, i.e. the moment the held state was
first reached. Timers are not polled while the simulation is paused (the car cannot
react then), so a pause during a trial delays its verdict to the first step after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..controls import STEERING_WHEEL_MAX_DEG

CORRECT, FAILURE, MISSED = 1, -1, -2
MISSED_RT_S = 10.0  # OpenDS logs misses with 10000 ms
EPS = 1e-9
STEER_2DEG = 2.0 / STEERING_WHEEL_MAX_DEG  # 0.004444, OpenDS's "2 degree" steering mark
STEER_3DEG = 3.0 / STEERING_WHEEL_MAX_DEG  # 0.006666
LANE_WIDEN_M = 0.75  # entering the target lane is measured on the band widened by this


@dataclass(frozen=True)
class ReactionResult:
    """One scored trial, as OpenDS's reactionData.xml holds it (times in seconds).

    `t_s` is the simulation time when it was scored, `start_t_s` when the timer armed,
    `experiment_time_s` the time since `startReactionMeasurement`. `extra` holds the
    additional timestamps (seconds after the start; NaN when the event did not happen).
    """

    timer_id: str
    kind: str  # key | laneChange | brake | steering
    group: str
    result: int
    reaction_time_s: float
    start_t_s: float
    t_s: float
    experiment_time_s: float
    comment: str = ""
    extra: dict[str, float] = field(default_factory=dict)


class CarView(Protocol):
    """What timers read from the world each step (the core adapts the World to this)."""

    t_s: float  # simulation time
    x_m: float
    z_m: float
    speed_mps: float
    steering: float
    accelerator: float
    brake: float
    keys: tuple[str, ...]

    def lane_at(self, x: float, margin_m: float = 0.75) -> str | None: ...

    def lane_band(self, lane_id: str) -> tuple[float, float] | None: ...


@dataclass
class Timer:
    """State common to all timers (times in simulation seconds)."""

    timer_id: str
    group: str
    comment: str
    start_t_s: float
    start_x_m: float = 0.0
    start_z_m: float = 0.0
    time_limit_s: float = 0.0  # 0 = no limit
    distance_limit_m: float = 0.0
    fail_sound: str = ""
    success_sound: str = ""
    armed: bool = True  # False: conditions to arm were not met; only the limit runs
    extra: dict[str, float] = field(default_factory=dict)
    kind: str = ""

    def limit_exceeded(self, car: CarView) -> bool:
        if self.time_limit_s > 0.0 and car.t_s - self.start_t_s > self.time_limit_s + EPS:
            return True
        if self.distance_limit_m > 0.0:
            return math.hypot(car.x_m - self.start_x_m, car.z_m - self.start_z_m) > self.distance_limit_m
        return False

    def mark(self, name: str, car: CarView) -> None:
        """Record the first time something happened (seconds after the start)."""
        if math.isnan(self.extra.get(name, math.nan)):
            self.extra[name] = car.t_s - self.start_t_s

    def update(self, car: CarView) -> tuple[int, float] | None:
        """(result, reaction time) once decided, else None."""
        raise NotImplementedError


@dataclass
class KeyTimer(Timer):
    """setupKeyReactionTimer: the first press of a listed key decides."""

    correct: frozenset[str] = frozenset()
    failure: frozenset[str] = frozenset()

    def update(self, car: CarView) -> tuple[int, float] | None:
        for k in car.keys:
            if k in self.correct:
                return CORRECT, car.t_s - self.start_t_s
            if k in self.failure:
                return FAILURE, car.t_s - self.start_t_s
        return None


@dataclass
class LaneChangeTimer(Timer):
    """setupLaneChangeReactionTimer (see OPENDS.md section 3)."""

    target_lane: str = ""
    min_steering_deg: float = 0.0
    allow_brake: bool = True
    hold_s: float = 2.0
    peak_steer_deg: float = 0.0
    hold_since: float | None = None

    def update(self, car: CarView) -> tuple[int, float] | None:
        steer = abs(car.steering)
        self.peak_steer_deg = max(self.peak_steer_deg, steer * STEERING_WHEEL_MAX_DEG)
        if steer >= STEER_2DEG - EPS:
            self.mark("steer_2deg_s", car)
        if steer >= STEER_3DEG - EPS:
            self.mark("steer_3deg_s", car)
        band = car.lane_band(self.target_lane)
        if band is not None and band[0] - LANE_WIDEN_M <= car.x_m <= band[1] + LANE_WIDEN_M:
            self.mark("enter_lane_s", car)
        if not self.allow_brake and car.brake > 0.0:
            return FAILURE, car.t_s - self.start_t_s
        if self.limit_exceeded(car):
            return MISSED, MISSED_RT_S
        if car.lane_at(car.x_m) == self.target_lane and self.peak_steer_deg >= self.min_steering_deg - EPS:
            if self.hold_since is None:
                self.hold_since = car.t_s
            if car.t_s - self.hold_since >= self.hold_s - EPS:
                self.extra["success_s"] = car.t_s - self.start_t_s
                return CORRECT, car.t_s - self.start_t_s - self.hold_s
        else:
            self.hold_since = None
        return None


@dataclass
class BrakeTimer(Timer):
    """setupBrakeReactionTimer (see OPENDS.md section 3)."""

    target_speed_mps: float = 60.0 / 3.6
    must_press_brake: bool = True
    allow_lane_change: bool = True
    hold_s: float = 2.0
    start_lane: str | None = None
    braked: bool = False
    hold_since: float | None = None

    def update(self, car: CarView) -> tuple[int, float] | None:
        if car.accelerator <= 0.0:
            self.mark("gas_release_s", car)
        if car.brake > 0.0:
            self.braked = True
            self.mark("brake_onset_s", car)
        if car.brake >= 0.8 - EPS:
            self.mark("brake_80_s", car)
        if not self.allow_lane_change:
            lane = car.lane_at(car.x_m)
            if lane is not None and self.start_lane is not None and lane != self.start_lane:
                return FAILURE, car.t_s - self.start_t_s
        if self.limit_exceeded(car):
            return MISSED, MISSED_RT_S
        if car.speed_mps <= self.target_speed_mps + EPS and (self.braked or not self.must_press_brake):
            if self.hold_since is None:
                self.hold_since = car.t_s
            if car.t_s - self.hold_since >= self.hold_s - EPS:
                self.extra["success_s"] = car.t_s - self.start_t_s
                return CORRECT, car.t_s - self.start_t_s - self.hold_s
        else:
            self.hold_since = None
        return None


@dataclass
class SteeringTimer(Timer):
    """setupSteeringReactionTimer: correct at the first steering-wheel movement of 2 degrees
    or more away from the wheel position at the start (OpenDS's ConTRe-style timer has no
    public specification; this threshold is its lane-change timer's first steering mark)."""

    start_steering: float = 0.0

    def update(self, car: CarView) -> tuple[int, float] | None:
        if abs(car.steering - self.start_steering) >= STEER_2DEG - EPS:
            return CORRECT, car.t_s - self.start_t_s
        return None


def new_extra(kind: str) -> dict[str, float]:
    names = {
        "laneChange": ("steer_2deg_s", "steer_3deg_s", "enter_lane_s", "success_s"),
        "brake": ("gas_release_s", "brake_onset_s", "brake_80_s", "success_s"),
    }.get(kind, ())
    return {n: math.nan for n in names}


def describe(timer: Timer) -> dict[str, Any]:
    """A JSON-friendly view of an active timer (for the viewer and the recorder)."""
    return {"timer_id": timer.timer_id, "kind": timer.kind, "group": timer.group, "armed": timer.armed, "start_t_s": timer.start_t_s}
