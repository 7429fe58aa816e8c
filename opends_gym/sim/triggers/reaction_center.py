"""The reaction center: arms timers by id, polls them, and keeps the scored results.

Why: OpenDS's `ReactionCenter` is one per run; `startReactionMeasurement` starts its
clock and every `setup*ReactionTimer` looks its timer up by id. Keeping that bookkeeping
here leaves each timer class with only its own scoring rule.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ...task.conditions import canonical_key
from ..events import EventLog
from .reactions import (
    MISSED,
    MISSED_RT_S,
    BrakeTimer,
    CarView,
    KeyTimer,
    LaneChangeTimer,
    ReactionResult,
    SteeringTimer,
    Timer,
    new_extra,
)


def _key_set(text: str) -> frozenset[str]:
    return frozenset(canonical_key(k) for k in text.split(",") if k.strip())


class ReactionCenter:
    """Active timers by id and the results so far (`results`, in scoring order)."""

    def __init__(self, events: EventLog, now: Callable[[], float]) -> None:
        self.events = events
        self._now = now  # simulation time, for the event log
        self.started = False
        self.started_at_s = 0.0
        self.timers: dict[str, Timer] = {}
        self.results: list[ReactionResult] = []

    # ------------------------------------------------------------------ arming
    def start(self, car: CarView) -> None:
        if not self.started:
            self.started = True
            self.started_at_s = car.t_s
            self.events.emit(self._now(), "reaction_measurement", "startReactionMeasurement")

    def setup(self, kind: str, args: dict[str, Any], car: CarView) -> None:
        """Arm (or re-arm) a timer; re-arming a running one logs a miss first."""
        timer_id = str(args["timer_id"])
        if not self.started:
            self.events.emit(
                self._now(), "warning", timer_id, message=f"{kind} reaction timer set up before startReactionMeasurement; ignored"
            )
            return
        old = self.timers.pop(timer_id, None)
        if old is not None and old.armed:
            self._score(old, MISSED, MISSED_RT_S, car, reason="re-armed")
        timer = self._build(kind, args, car)
        self.timers[timer_id] = timer
        self.events.emit(
            self._now(),
            "reaction_timer",
            timer_id,
            kind=kind,
            group=timer.group,
            armed=timer.armed,
            comment=timer.comment,
        )

    def _build(self, kind: str, a: dict[str, Any], car: CarView) -> Timer:
        common: dict[str, Any] = {
            "timer_id": str(a["timer_id"]),
            "group": str(a.get("reaction_group") or ""),
            "comment": str(a.get("comment") or ""),
            "start_t_s": car.t_s,
            "start_x_m": car.x_m,
            "start_z_m": car.z_m,
            "time_limit_s": float(a.get("time_limit_s") or 0.0),
            "distance_limit_m": float(a.get("distance_limit_m") or 0.0),
            "fail_sound": str(a.get("fail_sound") or ""),
            "success_sound": str(a.get("success_sound") or ""),
            "extra": new_extra(kind),
            "kind": kind,
        }
        if kind == "key":
            return KeyTimer(**common, correct=_key_set(a.get("correct_reaction") or ""), failure=_key_set(a.get("failure_reaction") or ""))
        if kind == "laneChange":
            start_lane = str(a["start_lane"])
            return (
                LaneChangeTimer(
                    **common,
                    target_lane=str(a["target_lane"]),
                    min_steering_deg=float(a.get("min_steering_angle_deg") or 0.0),
                    allow_brake=bool(a.get("allow_brake", True)),
                    hold_s=float(a.get("hold_lane_for_s", 2.0)),
                )
                if car.lane_at(car.x_m) == start_lane
                else _unarmed(LaneChangeTimer(**common, target_lane=str(a["target_lane"])))
            )
        if kind == "brake":
            timer = BrakeTimer(
                **common,
                target_speed_mps=float(a.get("target_speed_mps", 60.0 / 3.6)),
                must_press_brake=bool(a.get("must_press_brake_pedal", True)),
                allow_lane_change=bool(a.get("allow_lane_change", True)),
                hold_s=float(a.get("hold_speed_for_s", 2.0)),
                start_lane=car.lane_at(car.x_m),
            )
            return timer if car.speed_mps >= float(a.get("start_speed_mps", 80.0 / 3.6)) - 1e-9 else _unarmed(timer)
        if kind == "steering":
            return SteeringTimer(**common, start_steering=car.steering)
        raise ValueError(f"unknown reaction timer kind '{kind}'")

    # ------------------------------------------------------------------ polling
    def update(self, car: CarView) -> None:
        for timer_id in list(self.timers):
            timer = self.timers[timer_id]
            if not timer.armed:
                if timer.limit_exceeded(car):
                    del self.timers[timer_id]
                    self.events.emit(self._now(), "reaction_not_armed", timer_id, kind=timer.kind, group=timer.group)
                    self._sound(timer.fail_sound)
                continue
            decided = timer.update(car)
            if decided is not None:
                del self.timers[timer_id]
                self._score(timer, decided[0], decided[1], car)

    def close(self, car: CarView) -> None:
        """End of the run: every running timer is a miss (OpenDS logs them on close)."""
        for timer_id in list(self.timers):
            timer = self.timers.pop(timer_id)
            if timer.armed:
                self._score(timer, MISSED, MISSED_RT_S, car, reason="closed")

    def _score(self, timer: Timer, result: int, rt_s: float, car: CarView, reason: str = "") -> None:
        # times are differences of step times: rounding to the nanosecond removes the
        # float noise so they equal whole numbers of physics steps
        r = ReactionResult(
            timer_id=timer.timer_id,
            kind=timer.kind,
            group=timer.group,
            result=result,
            reaction_time_s=round(rt_s, 9),
            start_t_s=round(timer.start_t_s, 9),
            t_s=round(car.t_s, 9),
            experiment_time_s=round(car.t_s - self.started_at_s, 9),
            comment=timer.comment,
            extra={k: round(v, 9) for k, v in timer.extra.items() if not math.isnan(v)},
        )
        self.results.append(r)
        self.events.emit(
            self._now(),
            "reaction",
            timer.timer_id,
            kind=timer.kind,
            group=timer.group,
            result=result,
            reaction_time_s=r.reaction_time_s,
            comment=timer.comment,
            reason=reason,
            **{f"extra_{k}": v for k, v in r.extra.items()},
        )
        self._sound(timer.success_sound if result == 1 else timer.fail_sound)

    def _sound(self, sound_id: str) -> None:
        if sound_id:
            self.events.emit(self._now(), "sound", sound_id, op="play", reason="reaction")


def _unarmed(timer: Timer) -> Timer:
    timer.armed = False
    return timer
