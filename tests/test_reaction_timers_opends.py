"""Reaction timers against OpenDS's own classes (`eu.opends.reactionCenter`).

Each row of the tables is a scripted drive (speeds, positions, pedals, steering, keys at
60 Hz) and the outcome OpenDS's classes give for it: the method named in the row, read
line by line, decides. The lane-change and brake tables run through the public
`ReactionCenter` with the ReactionTest's real lane bands (0-4, 3.7 m wide, lane 2 at
x = -1.85..1.85) and, for the same rows, through the native batch's `TimerBatch`, which
must give identical results. Key and steering timers run through `World.step`, since
their inputs are driver controls.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from opends_gym.human.controls_builder import ControlsBuilder
from opends_gym.human.inputs.base import merge_frames
from opends_gym.human.inputs.joystick import AxisMap, FakeJoystick, FakeJoystickBackend, JoystickSource
from opends_gym.human.inputs.keyboard import KeyboardSource
from opends_gym.sim.controls import DriverControls
from opends_gym.sim.events import EventLog
from opends_gym.sim.road import RoadModel
from opends_gym.sim.triggers.core import CarState
from opends_gym.sim.triggers.reaction_center import ReactionCenter
from opends_gym.sim.triggers.reactions import ReactionResult
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import load_task
from opends_gym.vector.timers import KINDS, TimerBatch

from .conftest import CORPUS

DT = 1.0 / 60.0
KMH = 1.0 / 3.6
LANE_X = {"2": 0.0, "3": 3.7, "4": 7.4}  # lane centres (ReactionTest scenario.xml)


@pytest.fixture(scope="module")
def road() -> RoadModel:
    return RoadModel(load_task(CORPUS / "opends-cts" / "ReactionTest"))


# ---------------------------------------------------------------------- scripted drives
@dataclass
class Drive:
    """A car whose state is a function of time; `at(t)` returns the CarState fields."""

    speed_kmh: Callable[[float], float] = lambda t: 100.0
    x: Callable[[float], float] = lambda t: 0.0
    y: Callable[[float], float] = lambda t: 0.0
    z: Callable[[float], float] = lambda t: -30.0 * t
    steering: Callable[[float], float] = lambda t: 0.0
    accelerator: Callable[[float], float] = lambda t: 0.0
    brake: Callable[[float], float] = lambda t: 0.0


def step(t0: float) -> Callable[[float], float]:
    """0 before t0, 1 from t0 on (times are whole physics steps)."""
    return lambda t: 1.0 if t >= t0 - 1e-9 else 0.0


def piecewise(*points: tuple[float, float]) -> Callable[[float], float]:
    """The value of the last (from_t, value) pair whose from_t has come."""
    return lambda t: next(v for t0, v in reversed(points) if t >= t0 - 1e-9)


@dataclass(frozen=True)
class Case:
    rule: str  # "OpenDS Class.method: scripted inputs -> OpenDS's outcome"
    setups: tuple[tuple[float, str, dict[str, Any]], ...]  # (t, kind, typed action arguments)
    drive: Drive
    until_s: float
    expected: tuple[tuple[int, float, float], ...]  # (result, reaction time s, logged at s)
    groups: tuple[str, ...] = field(default=())


def brake_args(**kw: Any) -> dict[str, Any]:
    """setupBrakeReactionTimer's defaults (startSpeed 80, targetSpeed 60 km/h, hold 2000 ms)."""
    return {"timer_id": "b", "reaction_group": "brake", "start_speed_mps": 80 * KMH, "target_speed_mps": 60 * KMH} | kw


def lane_args(**kw: Any) -> dict[str, Any]:
    """setupLaneChangeReactionTimer from lane 2 to lane 3 (hold 2000 ms)."""
    return {"timer_id": "l", "reaction_group": "lane", "start_lane": "2", "target_lane": "3"} | kw


def car_at(t: float, d: Drive, road: RoadModel, keys: tuple[str, ...] = ()) -> CarState:
    return CarState(
        t_s=t,
        x_m=d.x(t),
        y_m=d.y(t),
        z_m=d.z(t),
        speed_mps=d.speed_kmh(t) * KMH,
        steering=d.steering(t),
        accelerator=d.accelerator(t),
        brake=d.brake(t),
        keys=keys,
        lanes={b.id: (b.x_min, b.x_max) for b in road.lanes},
        lane_fn=road.lane_id_at,
    )


def run_center(case: Case, road: RoadModel, with_center: bool = False) -> Any:
    """The drive through a started ReactionCenter: setups due at a step run before its poll,
    as the trigger core runs actions before timers. Returns the results (or the center)."""
    clock = [0.0]
    center = ReactionCenter(EventLog(), lambda: clock[0])
    center.start(car_at(0.0, case.drive, road))
    for k in range(round(case.until_s / DT) + 1):
        clock[0] = t = k * DT
        car = car_at(t, case.drive, road)
        for ts, kind, args in case.setups:
            if abs(ts - t) < DT / 2:
                center.setup(kind, args, car)
        center.update(car)
    return center if with_center else center.results


def run_native(case: Case, road: RoadModel) -> list[ReactionResult]:
    """The same drive through the native batch's timers (one env)."""
    batch = TimerBatch(1, tuple((b.x_min, b.x_max) for b in road.lanes))
    names = {"laneChange": "setupLaneChangeReactionTimer", "brake": "setupBrakeReactionTimer"}
    assert {KINDS[n] for n in names.values()} == {0, 1}
    for key, (_, kind, args) in enumerate(case.setups):
        batch.add_spec(key, names[kind], args, tuple(b.id for b in road.lanes))
    zero, one = np.zeros(1), np.ones(1, dtype=bool)
    d = case.drive
    for k in range(round(case.until_s / DT) + 1):
        t = k * DT
        arr = [np.array([v]) for v in (t, d.x(t), d.z(t), d.speed_kmh(t) * KMH, d.steering(t), d.brake(t))]
        for key, (ts, _, _) in enumerate(case.setups):
            if abs(ts - t) < DT / 2:
                batch.setup(np.array([0]), key, arr[0], arr[1], arr[2], arr[3], zero)
        batch.update(one, *arr, zero)
    return batch.results_of(0)


def outcomes(results: list[ReactionResult]) -> list[tuple[int, float, float]]:
    return [(r.result, r.reaction_time_s, r.t_s) for r in results]


def expected(case: Case) -> list[tuple[int, Any, Any]]:
    return [(res, pytest.approx(rt, abs=1e-6), pytest.approx(at, abs=1e-6)) for res, rt, at in case.expected]


# ---------------------------------------------------------------------- brake timer
BRAKE_CASES = [
    Case(
        "BrakeReactionTimer.update: hold clock starts when the speed drops below the target, braked or not: "
        "coasting below 60 km/h at 1.0 s, brake at 3.0 s (2 s hold) -> RT 1.0 s logged at 3.0 s",
        ((0.0, "brake", brake_args()),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), brake=step(3.0)),
        6.0,
        ((1, 1.0, 3.0),),
    ),
    Case(
        "BrakeReactionTimer.update: braking at 0.5 s, below target at 1.0 s -> RT 1.0 s logged at 3.0 s (after the hold)",
        ((0.0, "brake", brake_args()),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), brake=step(0.5)),
        6.0,
        ((1, 1.0, 3.0),),
    ),
    Case(
        "BrakeReactionTimer.update: mustPressBrakePedal false, coasting below target at 1.0 s -> RT 1.0 s logged at 3.0 s",
        ((0.0, "brake", brake_args(must_press_brake_pedal=False)),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0))),
        6.0,
        ((1, 1.0, 3.0),),
    ),
    Case(
        "BrakeReactionTimer.update: above the target again at 2.0 s clears timerSet; below again at 2.5 s -> RT 2.5 s at 4.5 s",
        ((0.0, "brake", brake_args()),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0), (2.0, 65.0), (2.5, 50.0)), brake=step(0.5)),
        6.0,
        ((1, 2.5, 4.5),),
    ),
    Case(
        "BrakeReactionTimer.update: timeExceeded is tested before hasChangedLanesWithoutPermission: "
        "leaving lane 2 on the step the 2 s limit passes -> missed (-2, 10 s)",
        ((0.0, "brake", brake_args(allow_lane_change=False, time_limit_s=2.0)),),
        Drive(x=piecewise((0.0, 0.0), (2.0 + DT, 3.7))),
        4.0,
        ((-2, 10.0, 2.0 + DT),),
    ),
    Case(
        "BrakeReactionTimer.hasChangedLanes: 'in no lane' (getCurrentLane null) is a lane change: "
        "off the road (x = 12 m) at 1.0 s -> failure (-1) at 1.0 s, RT 1.0 s",
        ((0.0, "brake", brake_args(allow_lane_change=False, time_limit_s=5.0)),),
        Drive(x=piecewise((0.0, 0.0), (1.0, 12.0))),
        6.0,
        ((-1, 1.0, 1.0),),
    ),
    Case(
        "BrakeReactionTimer.getCurrentLane: the raw lane band: x = 2.0 m is lane 3 (1.85..5.55, not narrowed) -> failure (-1) at 1.0 s",
        ((0.0, "brake", brake_args(allow_lane_change=False, time_limit_s=5.0)),),
        Drive(x=piecewise((0.0, 0.0), (1.0, 2.0))),
        6.0,
        ((-1, 1.0, 1.0),),
    ),
    Case(
        "BrakeReactionTimer.getCurrentLane: x = 1.5 m is still lane 2 in its raw band -> no failure; time limit 3 s -> missed",
        ((0.0, "brake", brake_args(allow_lane_change=False, time_limit_s=3.0)),),
        Drive(x=piecewise((0.0, 0.0), (1.0, 1.5))),
        5.0,
        ((-2, 10.0, 3.0 + DT),),
    ),
    Case(
        "BrakeReactionTimer.update: a failure's reaction time leaves out the hold clock's run: "
        "below target at 1.0 s, lane change at 2.0 s -> -1 with RT 2.0 - 1.0 = 1.0 s",
        ((0.0, "brake", brake_args(allow_lane_change=False)),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), x=piecewise((0.0, 0.0), (2.0, 3.7))),
        4.0,
        ((-1, 1.0, 2.0),),
    ),
    Case(
        "BrakeReactionTimer.setup: below startSpeed keeps the running trial, which goes on from the new startTime with the "
        "new limit (5 s from 1.0 s) -> one miss at 6.0 s, nothing logged at 1.0 s",
        ((0.0, "brake", brake_args(time_limit_s=3.0)), (1.0, "brake", brake_args(start_speed_mps=120 * KMH, time_limit_s=5.0))),
        Drive(),
        8.0,
        ((-2, 10.0, 6.0 + DT),),
    ),
    Case(
        "BrakeReactionTimer.setup: below startSpeed at 1.0 s; the running trial's RT counts from 1.0 s: "
        "braking below target at 2.0 s -> RT 1.0 s at 4.0 s, in the first setup's group",
        (
            (0.0, "brake", brake_args()),
            (1.0, "brake", brake_args(start_speed_mps=120 * KMH, reaction_group="second")),
        ),
        Drive(speed_kmh=piecewise((0.0, 100.0), (2.0, 50.0)), brake=step(2.0)),
        6.0,
        ((1, 1.0, 4.0),),
        ("brake",),
    ),
    Case(
        "ReactionTimer.setup: a setup that meets the precondition while a trial runs logs it as missed first",
        ((0.0, "brake", brake_args()), (1.0, "brake", brake_args(reaction_group="second", time_limit_s=1.0))),
        Drive(),
        3.0,
        ((-2, 10.0, 1.0), (-2, 10.0, 2.0 + DT)),
        ("brake", "second"),
    ),
    Case(
        "BrakeReactionTimer.timerSet is never reset by a setup: trial 1 ends correct below target (clock set at 1.0 s); "
        "trial 2 (startSpeed 30, target 60, no brake needed) set up at 5.0 s at 50 km/h -> correct at once, RT 1.0 - 5.0 = -4.0 s",
        (
            (0.0, "brake", brake_args()),
            (5.0, "brake", brake_args(start_speed_mps=30 * KMH, must_press_brake_pedal=False)),
        ),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), brake=step(0.5)),
        8.0,
        ((1, 1.0, 3.0), (1, -4.0, 5.0)),
    ),
    Case(
        "BrakeReactionTimer (a new timer id is a new object, timerSet false): the same trial 2 as timer 'b2' -> RT 0.0 s at 7.0 s",
        (
            (0.0, "brake", brake_args()),
            (5.0, "brake", brake_args(timer_id="b2", start_speed_mps=30 * KMH, must_press_brake_pedal=False)),
        ),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), brake=step(0.5)),
        8.0,
        ((1, 1.0, 3.0), (1, 0.0, 7.0)),
    ),
    Case(
        "BrakeReactionTimer.distanceExceeded: Vector3f.distance is 3-D: 8 m along and 7 m up (10.63 m) passes a 10 m limit",
        ((0.0, "brake", brake_args(distance_limit_m=10.0)),),
        Drive(z=piecewise((0.0, 0.0), (1.0, -8.0)), y=piecewise((0.0, 0.0), (1.0, 7.0))),
        2.0,
        ((-2, 10.0, 1.0),),
    ),
    Case(
        "BrakeReactionTimer.distanceExceeded: 8 m along on the flat is within a 10 m limit -> no result",
        ((0.0, "brake", brake_args(distance_limit_m=10.0)),),
        Drive(z=piecewise((0.0, 0.0), (1.0, -8.0))),
        2.0,
        (),
    ),
]


# ---------------------------------------------------------------------- lane-change timer
def into_lane_3(at: float) -> Callable[[float], float]:
    return piecewise((0.0, LANE_X["2"]), (at, LANE_X["3"]))


LANE_CASES = [
    Case(
        "LaneChangeReactionTimer.update: minSteeringAngle is compared with the raw steering value: peak 0.05 < 0.1 "
        "-> never correct; the 5 s limit -> missed",
        ((0.0, "laneChange", lane_args(min_steering_angle=0.1, time_limit_s=5.0)),),
        Drive(steering=piecewise((0.0, 0.0), (0.5, 0.05), (1.0, 0.0)), x=into_lane_3(1.0)),
        6.0,
        ((-2, 10.0, 5.0 + DT),),
    ),
    Case(
        "LaneChangeReactionTimer.update: peak steering 0.2 >= 0.1, in lane 3 from 1.0 s -> RT 1.0 s at 3.0 s",
        ((0.0, "laneChange", lane_args(min_steering_angle=0.1, time_limit_s=5.0)),),
        Drive(steering=piecewise((0.0, 0.0), (0.5, 0.2), (1.0, 0.0)), x=into_lane_3(1.0)),
        6.0,
        ((1, 1.0, 3.0),),
    ),
    Case(
        "LaneChangeReactionTimer.update: the hold clock starts on entering the lane whatever the steering: in lane 3 at 1.0 s, "
        "steering reaches 0.2 at 2.5 s -> RT 1.0 s at 3.0 s",
        ((0.0, "laneChange", lane_args(min_steering_angle=0.1)),),
        Drive(steering=piecewise((0.0, 0.0), (2.5, 0.2)), x=into_lane_3(1.0)),
        6.0,
        ((1, 1.0, 3.0),),
    ),
    Case(
        "LaneChangeReactionTimer.update: timeExceeded is tested before isBrakingWithoutPermission: "
        "the first brake on the step the 2 s limit passes -> missed (-2), not failure",
        ((0.0, "laneChange", lane_args(allow_brake=False, time_limit_s=2.0)),),
        Drive(brake=step(2.0 + DT)),
        3.0,
        ((-2, 10.0, 2.0 + DT),),
    ),
    Case(
        "LaneChangeReactionTimer.update: braking at 1.5 s with allowBrake false, in lane 3 since 1.0 s "
        "-> failure with RT 1.5 - 0.5 (hold run) = 1.0 s",
        ((0.0, "laneChange", lane_args(allow_brake=False)),),
        Drive(brake=step(1.5), x=into_lane_3(1.0)),
        3.0,
        ((-1, 1.0, 1.5),),
    ),
    Case(
        "LaneChangeReactionTimer.getCurrentLane: the lane band narrowed by halfCarWidth 0.75 m: x = 2.2 m is in no lane "
        "-> the hold clock does not run; the 3 s limit -> missed",
        ((0.0, "laneChange", lane_args(time_limit_s=3.0)),),
        Drive(x=piecewise((0.0, 0.0), (1.0, 2.2))),
        4.0,
        ((-2, 10.0, 3.0 + DT),),
    ),
    Case(
        "LaneChangeReactionTimer.setup: not in startLane at 1.0 s keeps the running trial from the new start: "
        "in lane 3 from 1.5 s -> RT 0.5 s at 3.5 s",
        ((0.0, "laneChange", lane_args()), (1.0, "laneChange", lane_args(start_lane="4", reaction_group="second"))),
        Drive(x=into_lane_3(1.5)),
        5.0,
        ((1, 0.5, 3.5),),
        ("lane",),
    ),
    Case(
        "LaneChangeReactionTimer.setup: not in startLane and no trial running -> nothing is logged",
        ((0.0, "laneChange", lane_args(start_lane="4", time_limit_s=1.0)),),
        Drive(x=into_lane_3(0.5)),
        3.0,
        (),
    ),
    Case(
        "ReactionCenter.setupBrakeReactionTimer: a timer id of another kind is closed (its trial missed) and replaced",
        ((0.0, "laneChange", lane_args(timer_id="x")), (1.0, "brake", brake_args(timer_id="x", time_limit_s=1.0))),
        Drive(),
        3.0,
        ((-2, 10.0, 1.0), (-2, 10.0, 2.0 + DT)),
        ("lane", "brake"),
    ),
]


@pytest.mark.parametrize("case", BRAKE_CASES + LANE_CASES, ids=lambda c: c.rule.split(":")[0] + ":" + c.rule[-40:])
def test_opends_outcome(case: Case, road: RoadModel) -> None:
    got = run_center(case, road)
    assert outcomes(got) == expected(case), case.rule
    if case.groups:
        assert tuple(r.group for r in got) == case.groups


NATIVE_CASES = [c for c in BRAKE_CASES + LANE_CASES if "3-D" not in c.rule and len({a["timer_id"] for _, _, a in c.setups}) == 1]


@pytest.mark.parametrize("case", NATIVE_CASES, ids=lambda c: c.rule[-40:])
def test_native_batch_gives_the_same_results(case: Case, road: RoadModel) -> None:
    single = [(r.result, r.reaction_time_s, r.t_s, r.start_t_s, r.experiment_time_s, r.group) for r in run_center(case, road)]
    native = [(r.result, r.reaction_time_s, r.t_s, r.start_t_s, r.experiment_time_s, r.group) for r in run_native(case, road)]
    assert native == single


def test_misses_are_logged_from_the_setup_and_correct_ones_from_the_start(road: RoadModel) -> None:
    """ReactionTimer.reportMissedReaction logs reactionTimer (the setup that armed the
    trial); BrakeReactionTimer.update logs startTime, which a failed setup overwrote."""
    case = next(c for c in BRAKE_CASES if "new limit" in c.rule)
    (miss,) = run_center(case, road)
    assert (miss.start_t_s, miss.experiment_time_s) == (0.0, 0.0)
    case = next(c for c in BRAKE_CASES if "in the first setup's group" in c.rule)
    (ok,) = run_center(case, road)
    assert ok.start_t_s == pytest.approx(1.0) and ok.experiment_time_s == pytest.approx(1.0)


def _sounds(case: Case, road: RoadModel) -> list[tuple[float, str]]:
    """(step time, sound id) of the sounds the drive plays."""
    return [(round(e.t_s, 6), e.source) for e in run_center(case, road, with_center=True).events.of_kind("sound")]


def test_failed_setups_play_the_fail_sound_at_their_limit(road: RoadModel) -> None:
    """BrakeReactionTimer.update's soundTimerIsActive block: a setup below startSpeed plays
    failSound once its time limit passes, and logs nothing; a running trial that misses on
    the same step plays it too (BrakeReactionTimer.reportMissedReaction)."""
    alone = Case("", ((0.0, "brake", brake_args(start_speed_mps=120 * KMH, time_limit_s=1.0, fail_sound="f2")),), Drive(), 3.0, ())
    assert _sounds(alone, road) == [(round(1.0 + DT, 6), "f2")] and not run_center(alone, road)
    both = Case(
        "",
        (
            (0.0, "brake", brake_args(fail_sound="f1", success_sound="ok")),
            (1.0, "brake", brake_args(start_speed_mps=120 * KMH, time_limit_s=1.0, fail_sound="f2")),
        ),
        Drive(),
        3.0,
        ((-2, 10.0, 2.0 + DT),),
    )
    assert _sounds(both, road) == [(round(2.0 + DT, 6), "f2"), (round(2.0 + DT, 6), "f2")]
    assert outcomes(run_center(both, road)) == expected(both)


def test_trial_log_times_as_opends_trial_logger(road: RoadModel) -> None:
    """TrialLogger keeps the first time of each mark; brakeRT_success is the reaction time."""
    case = Case(
        "",
        ((0.0, "brake", brake_args()),),
        Drive(speed_kmh=piecewise((0.0, 100.0), (1.0, 50.0)), accelerator=piecewise((0.0, 0.5), (0.25, 0.0)), brake=step(0.5)),
        4.0,
        (),
    )
    (r,) = run_center(case, road)
    assert r.extra == pytest.approx({"gas_release_s": 0.25, "brake_onset_s": 0.5, "brake_80_s": 0.5, "success_s": 1.0})


# ---------------------------------------------------------------------- key and steering timers (through World.step)
NS = 'xmlns="http://opends.eu/drivingtask/interaction"'


def _trigger(tid: str, action: str) -> str:
    return (
        f'<trigger id="{tid}" priority="1"><activities><activity id="{tid}_a">{action}</activity></activities>'
        f"<condition>remote:{tid}</condition></trigger>"
    )


def _action(name: str, **params: str) -> str:
    body = "".join(f'<parameter name="{k}" value="{v}"/>' for k, v in params.items())
    return f'<action id="{name}" delay="0" repeat="0">{body}</action>'


@pytest.fixture(scope="module")
def timer_task(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The ReactionTest with remote triggers that start the measurement and set up a
    steering timer and a key timer."""
    import shutil

    folder = Path(tmp_path_factory.mktemp("timers")) / "ReactionTest"
    shutil.copytree(CORPUS / "opends-cts" / "ReactionTest", folder)
    triggers = (
        _trigger("start", _action("startReactionMeasurement"))
        + _trigger("steer", _action("setupSteeringReactionTimer", timerID="s", reactionGroup="steer"))
        + _trigger("key", _action("setupKeyReactionTimer", timerID="k", reactionGroup="key", correctReaction="KEY_A", failureReaction="B"))
        + _trigger(
            "brake",
            _action(
                "setupBrakeReactionTimer", timerID="b", congruenceClass="brake", startSpeed="40", targetSpeed="35", holdSpeedFor="2000"
            ),
        )
    )
    (folder / "interaction.xml").write_text(f'<?xml version="1.0"?>\n<interaction {NS}><triggers>{triggers}</triggers></interaction>\n')
    return load_task(folder)


def _armed_world(task: Any, timer: str, before: DriverControls | None = None) -> tuple[World, float]:
    w = World(task, WorldConfig(traffic=False))
    w.step(DriverControls(remote_triggers=("start",)))
    if before is not None:
        w.step(before)
    w.step(DriverControls(remote_triggers=(timer,), steering=before.steering if before else 0.0))
    return w, w.t_s


def _drive(w: World, until_s: float, controls: Callable[[float], DriverControls]) -> None:
    """Step up to and including the step at until_s; controls(t) drive the step ending at t."""
    while w.t_s < until_s - w.dt_s / 2:
        w.step(controls(w.t_s + w.dt_s))


def _axis(v: float) -> DriverControls:
    return DriverControls(steering=v)  # an agent's continuous steering: an analogue axis


def _keys(v: float) -> DriverControls:
    return DriverControls(steering=v, steering_axis=False)  # keyboard steering (STEER_LEFT/RIGHT)


STEERING_CASES: list[tuple[str, DriverControls | None, Callable[[float], DriverControls], tuple[int, float] | None]] = [
    ("SteeringReactionTimer.setup maps only a JoyAxisTrigger: keyboard steering 0.3 from +0.5 s -> no reaction", None,
     lambda t: _keys(0.3), None),
    ("SteeringReactionTimer: axis steering 0.3 from +0.5 s (leaves jME's 0.05 dead zone) -> correct, RT 0.5 s", None,
     lambda t: _axis(0.3), (1, 0.5)),
    ("SteeringReactionTimer: axis steering 0.04 stays inside jME's 0.05 dead zone -> no reaction", None, lambda t: _axis(0.04), None),
    ("SteeringReactionTimer: axis steering -0.3 (the other direction: both JoyAxisTriggers are mapped) -> correct, RT 0.5 s", None,
     lambda t: _axis(-0.3), (1, 0.5)),
]  # fmt: skip


@pytest.mark.parametrize("rule, before, drive, outcome", STEERING_CASES, ids=lambda v: v[-40:] if isinstance(v, str) else "")
def test_steering_timer_hears_axis_events_only(timer_task: Any, rule: str, before: Any, drive: Any, outcome: Any) -> None:
    w, armed = _armed_world(timer_task, "steer")
    _drive(w, armed + 0.5 - w.dt_s, lambda t: _axis(0.0))
    _drive(w, armed + 2.0, drive)
    w.triggers.close_timers()
    (r,) = w.triggers.reactions
    if outcome is None:
        assert (r.result, r.reaction_time_s) == (-2, 10.0), rule
    else:
        assert (r.result, r.reaction_time_s) == (outcome[0], pytest.approx(outcome[1], abs=1e-9)), rule


def test_steering_axis_held_out_of_the_dead_zone_must_leave_it_again(timer_task: Any) -> None:
    """jME InputManager.invokeAnalogsAndActions calls onAction only when the axis value
    leaves the dead zone (or crosses over): a wheel held at 0.3 through the setup answers
    only once it has come back to the centre (1.0 s) and turned again (1.5 s)."""
    w, armed = _armed_world(timer_task, "steer", before=_axis(0.3))
    _drive(w, armed + 1.0 - w.dt_s, lambda t: _axis(0.3 + 0.1 * (t - armed)))  # turned further: still no event
    _drive(w, armed + 1.5 - w.dt_s, lambda t: _axis(0.0))
    _drive(w, armed + 2.0, lambda t: _axis(0.3))
    (r,) = w.triggers.reactions
    assert (r.result, r.reaction_time_s) == (1, pytest.approx(1.5, abs=1e-9))


def test_human_keyboard_steering_is_not_an_axis_and_the_wheel_is(timer_task: Any) -> None:
    """The human runner's path: KeyboardSource and JoystickSource frames, merged, through
    ControlsBuilder into World.step; only the wheel answers the steering timer."""
    wheel = FakeJoystick(axes=4)
    pad = JoystickSource(FakeJoystickBackend(wheel), {"steering": AxisMap(0, 0)})
    kb = KeyboardSource()
    w, armed = _armed_world(timer_task, "steer")
    build = ControlsBuilder(w)
    kb.handle_key("KEY_LEFT", True)  # keyboard steering left, wheel centred
    for _ in range(30):
        c = build.build(merge_frames([pad.poll(w.t_s), kb.poll(w.t_s)]))
        assert c.steering != 0.0 and not c.steering_axis
        w.step(c)
    assert not w.triggers.reactions
    kb.handle_key("KEY_LEFT", False)
    wheel.axes[0] = -0.4  # the wheel turned left
    c = build.build(merge_frames([pad.poll(w.t_s), kb.poll(w.t_s)]))
    assert c.steering_axis
    w.step(c)
    (r,) = w.triggers.reactions
    assert (r.result, r.reaction_time_s) == (1, pytest.approx(w.t_s - armed, abs=1e-9))


@pytest.mark.parametrize(
    "rule, keys, outcome",
    [
        (
            "ReactionTimer.update checks correctReactionReported first: failure and correct key in one step -> correct",
            ("KEY_B", "KEY_A"),
            1,
        ),
        ("KeyReactionTimer: the failure key alone -> failure", ("KEY_B",), -1),
        ("KeyReactionTimer: the correct key alone -> correct", ("a",), 1),
    ],
)
def test_key_timer(timer_task: Any, rule: str, keys: tuple[str, ...], outcome: int) -> None:
    w, armed = _armed_world(timer_task, "key")
    _drive(w, armed + 0.5 - w.dt_s, lambda t: DriverControls())
    w.step(DriverControls(keys=keys))
    (r,) = w.triggers.reactions
    assert (r.result, r.reaction_time_s) == (outcome, pytest.approx(0.5, abs=1e-9)), rule


def test_brake_timer_in_a_world_counts_from_the_first_step_below_the_target(timer_task: Any) -> None:
    """BrakeReactionTimer.update through the physics: accelerate past 40 km/h, arm
    (startSpeed 40, targetSpeed 35, hold 2 s), coast, brake 2.5 s after falling below 35 km/h
    -> correct at the brake step, RT = first step at or below 35 km/h minus the setup."""
    w = World(timer_task, WorldConfig(traffic=False))
    w.step(DriverControls(remote_triggers=("start",)))
    while w.ego.state.u < 42 * KMH:
        w.step(DriverControls(accelerator=1.0))
    w.step(DriverControls(remote_triggers=("brake",)))
    armed = w.t_s
    below = None
    while below is None or w.t_s < below + 2.5 - 1e-9:
        w.step(DriverControls())
        if below is None and w.ego.state.u <= 35 * KMH + 1e-9:
            below = w.t_s
        assert w.t_s < armed + 30, "the car never coasted below 35 km/h"
    assert not w.triggers.reactions  # held 2 s, but not braked yet
    w.step(DriverControls(brake=0.5))
    (r,) = w.triggers.reactions
    assert r.result == 1 and r.t_s == pytest.approx(w.t_s)
    assert r.reaction_time_s == pytest.approx(below - armed, abs=1e-9)


def test_recordings_keep_the_steering_source() -> None:
    """A human drive is recorded as `ControlsAction` vectors and /controls messages: the
    steering source survives both, and recordings made before it read as axis steering."""
    import gymnasium as gym

    import opends_gym  # noqa: F401  (registers the ids)
    from opends_gym.record.messages import controls_from_message, controls_message

    env = gym.make("OpenDS/ReactionTest-v0", action="controls")
    act = env.unwrapped.act_type
    keyboard = DriverControls(steering=0.3, steering_axis=False)
    assert act.to_controls(act.encode(keyboard)).steering_axis is False
    assert act.to_controls(act.encode(DriverControls(steering=0.3))).steering_axis is True
    assert act.to_controls(act.encode(keyboard)[:-1]).steering_axis is True  # a 35-value vector of an older recording
    w = env.unwrapped.world
    assert controls_from_message(controls_message(w, keyboard)).steering_axis is False
    assert "steering_axis" not in controls_message(w, DriverControls(steering=0.3))  # as before the field
    env.close()
