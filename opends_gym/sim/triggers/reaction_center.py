"""The reaction center: arms timers by id, polls them, and keeps the scored results.

Why: OpenDS's `ReactionCenter` is one per run; `startReactionMeasurement` starts its
clock and every `setup*ReactionTimer` looks its timer up by id. Keeping that bookkeeping
here leaves each timer class with only its own scoring rule.

As in OpenDS, a timer id keeps its timer object (and with it the hold clock) for the
whole run; a setup of another kind closes it (a running trial is a miss) and makes a new
one. `known` holds every timer; `timers` only those that need polling (a running trial or
a failed setup's sound timer).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..events import EventLog
from .reactions import MISSED, MISSED_RT_S, TIMER_CLASSES, CarView, HoldTimer, ReactionResult, Timer, Verdict


class ReactionCenter:
    """Timers by id and the results so far (`results`, in scoring order)."""

    def __init__(self, events: EventLog, now: Callable[[], float]) -> None:
        self.events = events
        self._now = now  # simulation time, for the event log
        self.started = False
        self.started_at_s = 0.0
        self.known: dict[str, Timer] = {}
        self.timers: dict[str, Timer] = {}
        self.results: list[ReactionResult] = []

    def clear(self) -> None:
        self.known.clear()
        self.timers.clear()
        self.results.clear()
        self.started = False
        self.started_at_s = 0.0

    # ------------------------------------------------------------------ arming
    def start(self, car: CarView) -> None:
        if not self.started:
            self.started = True
            self.started_at_s = car.t_s
            self.events.emit(self._now(), "reaction_measurement", "startReactionMeasurement")

    def setup(self, kind: str, args: dict[str, Any], car: CarView) -> None:
        """ReactionCenter.setup*ReactionTimer, then the timer's own setup."""
        timer_id = str(args["timer_id"])
        if not self.started:
            self.events.emit(
                self._now(), "warning", timer_id, message=f"{kind} reaction timer set up before startReactionMeasurement; ignored"
            )
            return
        if kind not in TIMER_CLASSES:
            raise ValueError(f"unknown reaction timer kind '{kind}'")
        timer = self.known.get(timer_id)
        if timer is not None and timer.kind != kind:  # another kind: close it, make a new one (last in the list)
            if timer.armed:
                self._miss(timer, car, reason="closed")
            del self.known[timer_id]
            timer = None
        if timer is None:
            timer = TIMER_CLASSES[kind](timer_id=timer_id, kind=kind)
            self.known[timer_id] = timer
        ok = timer.precondition(args, car)
        if ok:
            if timer.armed:  # ReactionTimer.setup: the running trial is a miss
                self._miss(timer, car, reason="re-armed")
            timer.arm(args, car)
        else:  # the running trial (if any) goes on, from the new start and with the new limits
            timer.restart_limits(args, car)
            timer.sound_timer = True
        self.timers[timer_id] = timer
        self.events.emit(
            self._now(),
            "reaction_timer",
            timer_id,
            kind=kind,
            group=str(args.get("reaction_group") or ""),
            armed=ok,
            running=timer.armed,
            comment=str(args.get("comment") or ""),
        )

    # ------------------------------------------------------------------ polling
    def update(self, car: CarView) -> None:
        """ReactionCenter.update: the timers in the order they were made."""
        for timer_id, timer in list(self.known.items()):
            if timer_id not in self.timers:
                continue
            timer.listen(car)
            verdict = timer.update(car)
            if verdict is not None:
                self._end(timer, verdict, car)
            if timer.sound_due(car):
                self._sound(timer.fail_sound)
            if not (timer.armed or timer.sound_timer):
                del self.timers[timer_id]

    def close(self, car: CarView) -> None:
        """End of the run: every running timer is a miss (ReactionCenter.close)."""
        for timer in self.known.values():
            if timer.armed:
                self._miss(timer, car, reason="closed")
        self.timers.clear()

    def _miss(self, timer: Timer, car: CarView, reason: str) -> None:
        self._end(timer, (MISSED, MISSED_RT_S), car, reason)

    def _end(self, timer: Timer, verdict: Verdict, car: CarView, reason: str = "") -> None:
        result, rt_s = verdict
        timer.armed = False
        # a miss is logged from the setup time (ReactionTimer.reportMissedReaction), the
        # others of brake and lane-change timers from their startTime
        start = timer.start_t_s if isinstance(timer, HoldTimer) and result != MISSED else timer.armed_t_s
        # times are differences of step times: rounding to the nanosecond removes the
        # float noise so they equal whole numbers of physics steps
        r = ReactionResult(
            timer_id=timer.timer_id,
            kind=timer.kind,
            group=timer.group,
            result=result,
            reaction_time_s=round(rt_s, 9),
            start_t_s=round(start, 9),
            t_s=round(car.t_s, 9),
            experiment_time_s=round(start - self.started_at_s, 9),
            comment=timer.comment,
            extra={k: round(v, 9) for k, v in timer.extra.items()},
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
        # KeyReactionTimer and SteeringReactionTimer play no sounds (their fields are empty)
        self._sound(timer.success_sound if result == 1 else timer.fail_sound)

    def _sound(self, sound_id: str) -> None:
        if sound_id:
            self.events.emit(self._now(), "sound", sound_id, op="play", reason="reaction")
