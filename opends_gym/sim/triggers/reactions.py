"""Reaction timers with OpenDS's semantics, measured in simulation time.

Why: the reaction measurements are what make a driving task an experiment, so they must
score a drive exactly as OpenDS (`eu.opends.reactionCenter`) would. OpenDS polls its
timers once per rendered frame with the wall clock; here they are polled once per physics
step with the simulation clock, so a reaction time is exact to the physics step and
repeatable. Everything else follows OpenDS's classes rule by rule (docs/reaction-timers.md
lists the rules with the class and method each comes from).

Result codes: 1 correct, -1 failure, -2 missed (logged with 10 s, OpenDS's 10000 ms).
Timers are not polled while the simulation is paused (the car cannot react then), so a
pause during a trial delays its verdict to the first step after.

A timer object lives as long as its timer id keeps its kind (`ReactionCenter.setup*`
replaces it only when the kind changes), and like OpenDS's it keeps its hold clock
(`timerSet`) from one trial to the next.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

CORRECT, FAILURE, MISSED = 1, -1, -2
MISSED_RT_S = 10.0  # ReactionTimer.reportMissedReaction logs 10000 ms
EPS = 1e-9
# LaneChangeReactionTimer.update's two steering marks (raw steering wheel state; OpenDS's
# trial log calls them 2 and 3 degrees)
STEER_MARK_2 = 0.004444
STEER_MARK_3 = 0.006666
HALF_CAR_WIDTH_M = 0.75  # LaneChangeReactionTimer.halfCarWidth: lane bands narrowed/widened by it
AXIS_DEAD_ZONE = 0.05  # jME InputManager's global joystick axis dead zone


@dataclass(frozen=True)
class ReactionResult:
    """One scored trial, as OpenDS's reactionData.xml holds it (times in seconds).

    `t_s` is the simulation time when it was scored, `start_t_s` the trial's start as
    OpenDS logs it (`absoluteTime`), `experiment_time_s` that start relative to
    `startReactionMeasurement` (`experimentTime`: ReactionLogger.add's relativeStartTime).
    `extra` holds the trial log's timestamps (seconds after the start; absent when the
    event did not happen).
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
    y_m: float
    z_m: float
    speed_mps: float
    steering: float  # the steering wheel state, -1..1 (Car.getSteeringWheelState)
    accelerator: float
    brake: float
    keys: tuple[str, ...]
    axis_event: bool  # the steering joystick axis left its dead zone this step

    def lane_at(self, x: float, margin_m: float = 0.75) -> str | None: ...

    def lane_band(self, lane_id: str) -> tuple[float, float] | None: ...


Verdict = tuple[int, float]  # (result code, reaction time in s)


@dataclass
class Timer:
    """State common to all timers (ReactionTimer's fields; times in simulation seconds).

    `armed` is OpenDS's timerIsActive. `armed_t_s` is when the running trial was set up
    (ReactionTimer.reactionTimer: misses are logged from it); `start_t_s` and the start
    position are BrakeReactionTimer/LaneChangeReactionTimer.startTime and startPosition,
    which a setup whose precondition fails overwrites.
    """

    timer_id: str
    kind: str = ""
    group: str = ""
    comment: str = ""
    armed_t_s: float = 0.0
    start_t_s: float = 0.0
    start_x_m: float = 0.0
    start_y_m: float = 0.0
    start_z_m: float = 0.0
    time_limit_s: float = 0.0  # 0 = no limit
    distance_limit_m: float = 0.0
    fail_sound: str = ""
    success_sound: str = ""
    armed: bool = False
    sound_timer: bool = False  # soundTimerIsActive: a failed setup plays failSound at its limit
    correct_reported: bool = False
    failure_reported: bool = False
    extra: dict[str, float] = field(default_factory=dict)

    # ------------------------------------------------------------------ setup
    def precondition(self, args: dict[str, Any], car: CarView) -> bool:
        """Whether a setup with these arguments starts a trial (key and steering timers: always)."""
        return True

    def arm(self, args: dict[str, Any], car: CarView) -> None:
        """ReactionTimer.setup (the running trial, if any, has been logged as missed)."""
        self.group = str(args.get("reaction_group") or "")
        self.comment = str(args.get("comment") or "")
        self.armed_t_s = car.t_s
        self.correct_reported = self.failure_reported = False
        self.armed = True
        self.extra = {}

    def restart_limits(self, args: dict[str, Any], car: CarView) -> None:
        """The part of a setup both branches of Brake/LaneChangeReactionTimer.setup share:
        start time and position, limits and fail sound are overwritten."""
        self.start_t_s = car.t_s
        self.start_x_m, self.start_y_m, self.start_z_m = car.x_m, car.y_m, car.z_m
        self.time_limit_s = float(args.get("time_limit_s") or 0.0)
        self.distance_limit_m = float(args.get("distance_limit_m") or 0.0)
        self.fail_sound = str(args.get("fail_sound") or "")

    # ------------------------------------------------------------------ polling
    def limit_exceeded(self, car: CarView) -> bool:
        """timeExceeded() || distanceExceeded(): the distance is 3-D (Vector3f.distance)."""
        if self.time_limit_s > 0.0 and car.t_s - self.start_t_s > self.time_limit_s + EPS:
            return True
        if self.distance_limit_m > 0.0:
            d = math.hypot(car.x_m - self.start_x_m, car.y_m - self.start_y_m, car.z_m - self.start_z_m)
            return d > self.distance_limit_m
        return False

    def mark(self, name: str, car: CarView) -> None:
        """TrialLogger.setXxx: keep the first time something happened (s after the start)."""
        if name not in self.extra:
            self.extra[name] = car.t_s - self.start_t_s

    def listen(self, car: CarView) -> None:
        """The ReactionListener's part: input events this step set the report flags."""

    def update(self, car: CarView) -> Verdict | None:
        """ReactionTimer.update: a reported reaction is scored from the setup time."""
        if not self.armed:
            return None
        if self.correct_reported:
            return CORRECT, car.t_s - self.armed_t_s
        if self.failure_reported:
            return FAILURE, car.t_s - self.armed_t_s
        return None

    def sound_due(self, car: CarView) -> bool:
        """The sound timer of a failed setup: True once, when its limit passes."""
        if self.sound_timer and self.limit_exceeded(car):
            self.sound_timer = False
            return True
        return False


@dataclass
class KeyTimer(Timer):
    """KeyReactionTimer: the keys of the correct and failure lists are mapped while the
    trial runs; a press reports. Both in one step: ReactionTimer.update checks correct first."""

    correct: frozenset[str] = frozenset()
    failure: frozenset[str] = frozenset()

    def arm(self, args: dict[str, Any], car: CarView) -> None:
        super().arm(args, car)
        self.correct = key_set(str(args.get("correct_reaction") or ""))
        self.failure = key_set(str(args.get("failure_reaction") or ""))

    def listen(self, car: CarView) -> None:
        if self.armed:
            for k in car.keys:
                self.correct_reported |= k in self.correct
                self.failure_reported |= k in self.failure


@dataclass
class SteeringTimer(Timer):
    """SteeringReactionTimer: maps the steering joystick axis (both directions) to the
    correct reaction. jME's InputManager calls the listener's onAction when the axis leaves
    its dead zone, so a reaction is the first step whose steering comes from an analogue
    axis and leaves the dead zone; keyboard steering never counts (no axis event)."""

    def listen(self, car: CarView) -> None:
        if self.armed and car.axis_event:
            self.correct_reported = True


@dataclass
class HoldTimer(Timer):
    """What Brake- and LaneChangeReactionTimer share: a held state, limits and sounds."""

    hold_s: float = 2.0
    hold_set: bool = False  # timerSet: never reset by a setup
    hold_t_s: float = 0.0  # timer

    def restart(self, args: dict[str, Any], car: CarView) -> None:
        """The OK branch of setup after super.setup: start, limits, sounds, task values."""
        self.restart_limits(args, car)
        self.success_sound = str(args.get("success_sound") or "")
        self.sound_timer = False

    def hold(self, car: CarView, held: bool) -> bool:
        """The hold clock: starts when `held` first holds, stops when it does not; True once
        it has run for hold_s."""
        if not held:
            self.hold_set = False
            return False
        if not self.hold_set:
            self.hold_t_s, self.hold_set = car.t_s, True
        return car.t_s - self.hold_t_s >= self.hold_s - EPS

    def verdict(self, car: CarView) -> Verdict | None:
        """The end of update(): the reaction time leaves out the hold clock's run so far."""
        if not (self.correct_reported or self.failure_reported):
            return None
        offset = car.t_s - self.hold_t_s if self.hold_set else 0.0
        rt = car.t_s - self.start_t_s - offset
        if self.correct_reported:
            self.extra["success_s"] = rt
            return CORRECT, rt
        return FAILURE, rt


@dataclass
class LaneChangeTimer(HoldTimer):
    """LaneChangeReactionTimer."""

    target_lane: str = ""
    min_steering: float = 0.0  # compared with the raw steering wheel state (not degrees)
    allow_brake: bool = True
    peak_steering: float = 0.0  # steeringAngle: the largest |steering| since the setup

    def precondition(self, args: dict[str, Any], car: CarView) -> bool:
        return car.lane_at(car.x_m, HALF_CAR_WIDTH_M) == str(args["start_lane"])

    def arm(self, args: dict[str, Any], car: CarView) -> None:
        super().arm(args, car)
        self.restart(args, car)
        self.target_lane = str(args["target_lane"])
        self.min_steering = float(args.get("min_steering_angle") or 0.0)
        self.allow_brake = bool(args.get("allow_brake", True))
        self.hold_s = float(args.get("hold_lane_for_s", 2.0))
        self.peak_steering = 0.0

    def update(self, car: CarView) -> Verdict | None:
        if not self.armed:
            return None
        steer = abs(car.steering)
        self.peak_steering = max(self.peak_steering, steer)
        if steer >= STEER_MARK_2:
            self.mark("steer_2deg_s", car)
        if steer >= STEER_MARK_3:
            self.mark("steer_3deg_s", car)
        band = car.lane_band(self.target_lane)
        if band is not None and band[0] - HALF_CAR_WIDTH_M <= car.x_m <= band[1] + HALF_CAR_WIDTH_M:
            self.mark("enter_lane_s", car)
        if self.limit_exceeded(car):
            return MISSED, MISSED_RT_S
        if not self.allow_brake and car.brake > 0.0:
            self.failure_reported = True
        elif self.hold(car, car.lane_at(car.x_m, HALF_CAR_WIDTH_M) == self.target_lane) and self.peak_steering >= self.min_steering - EPS:
            self.correct_reported = True  # (the hold clock runs whatever the steering)
        return self.verdict(car)


@dataclass
class BrakeTimer(HoldTimer):
    """BrakeReactionTimer."""

    target_speed_mps: float = 60.0 / 3.6
    must_press_brake: bool = True
    allow_lane_change: bool = True
    start_lane: str | None = None
    braked: bool = False  # hasPressedBrakepedal

    def precondition(self, args: dict[str, Any], car: CarView) -> bool:
        return car.speed_mps >= float(args.get("start_speed_mps", 80.0 / 3.6)) - EPS

    def arm(self, args: dict[str, Any], car: CarView) -> None:
        super().arm(args, car)
        self.restart(args, car)
        self.target_speed_mps = float(args.get("target_speed_mps", 60.0 / 3.6))
        self.must_press_brake = bool(args.get("must_press_brake_pedal", True))
        self.allow_lane_change = bool(args.get("allow_lane_change", True))
        self.hold_s = float(args.get("hold_speed_for_s", 2.0))
        self.start_lane = car.lane_at(car.x_m, 0.0)  # getCurrentLane: the raw band
        self.braked = False

    def update(self, car: CarView) -> Verdict | None:
        if not self.armed:
            return None
        self.braked = self.braked or car.brake > 0.0
        if car.accelerator <= 0.0:
            self.mark("gas_release_s", car)
        if car.brake > 0.0:
            self.mark("brake_onset_s", car)
        if car.brake >= 0.8 - EPS:
            self.mark("brake_80_s", car)
        if self.limit_exceeded(car):
            return MISSED, MISSED_RT_S
        if not self.allow_lane_change and car.lane_at(car.x_m, 0.0) != self.start_lane:
            self.failure_reported = True  # hasChangedLanes: "in no lane" is another lane
        elif self.hold(car, car.speed_mps <= self.target_speed_mps + EPS) and (self.braked or not self.must_press_brake):
            self.correct_reported = True  # (the hold clock runs braked or not)
        return self.verdict(car)


TIMER_CLASSES: dict[str, type[Timer]] = {"key": KeyTimer, "laneChange": LaneChangeTimer, "brake": BrakeTimer, "steering": SteeringTimer}


def key_set(text: str) -> frozenset[str]:
    """KeyReactionTimer.addMapping's comma-separated key list, as canonical key names."""
    from ...task.conditions import canonical_key

    return frozenset(canonical_key(k) for k in text.split(",") if k.strip())


def axis_event(steering: float, previous: float) -> bool:
    """Does an axis moving from `previous` to `steering` fire a jME action? (InputManager.
    onJoyAxisEventQueued: when it leaves the dead zone, or crosses to the other side.)"""
    if abs(steering) < AXIS_DEAD_ZONE:
        return False
    return abs(previous) < AXIS_DEAD_ZONE or (previous < 0.0) != (steering < 0.0)


def describe(timer: Timer) -> dict[str, Any]:
    """A JSON-friendly view of an active timer (for the viewer and the recorder)."""
    return {"timer_id": timer.timer_id, "kind": timer.kind, "group": timer.group, "armed": timer.armed, "start_t_s": timer.start_t_s}
