"""The trigger core through the public interface: World + DriverControls + event log."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import action_spec, load_task

from .conftest import CORPUS

NS = 'xmlns="http://opends.eu/drivingtask/interaction"'


def _with_interaction(task_copy, body: str) -> Path:
    """The corpus ReactionTest with its interaction.xml replaced by `body`."""
    folder = task_copy("opends-cts/ReactionTest")
    (folder / "interaction.xml").write_text(f'<?xml version="1.0"?>\n<interaction {NS}>\n{body}\n</interaction>\n', encoding="utf-8")
    return folder


def _remote_trigger(tid: str, remote: str, actions: str, priority: int = 1) -> str:
    return (
        f'<trigger id="{tid}" priority="{priority}"><activities><activity id="{tid}_a">{actions}</activity></activities>'
        f"<condition>remote:{remote}</condition></trigger>"
    )


def _message(text: str, delay: float = 0.0, repeat: int = 0) -> str:
    return f'<action id="sendMessage" delay="{delay}" repeat="{repeat}"><parameter name="text" value="{text}"/></action>'


def _world(folder: Path) -> World:
    return World(load_task(folder), WorldConfig(traffic=False))


def _step_until(w: World, t_s: float, c: DriverControls | None = None) -> None:
    while w.t_s < t_s - 1e-9:
        w.step(c)


def _messages(w: World) -> list[tuple[float, str]]:
    return [(round(e.t_s, 6), e.params["text"]) for e in w.events.of_kind("message")]


def test_delay_counts_simulation_seconds(task_copy) -> None:
    folder = _with_interaction(
        task_copy, "<triggers>" + _remote_trigger("t", "go", _message("now") + _message("later", delay=0.5)) + "</triggers>"
    )
    w = _world(folder)
    _step_until(w, 1.0)
    fire_t = w.t_s + w.dt_s
    w.step(DriverControls(remote_triggers=("go",)))
    _step_until(w, 3.0)
    msgs = _messages(w)
    assert msgs[0] == (round(fire_t, 6), "now")
    assert msgs[1][1] == "later" and abs(msgs[1][0] - (fire_t + 0.5)) < w.dt_s + 1e-9 and msgs[1][0] >= fire_t + 0.5 - 1e-9


def test_repeat_caps_executions_and_zero_is_unlimited(task_copy) -> None:
    folder = _with_interaction(
        task_copy, "<triggers>" + _remote_trigger("t", "go", _message("capped", repeat=2) + _message("free", repeat=0)) + "</triggers>"
    )
    w = _world(folder)
    for k in range(4):  # four firings 2.5 s apart: the lock has expired each time
        _step_until(w, 1.0 + 2.5 * k)
        w.step(DriverControls(remote_triggers=("go",)))
    texts = [t for _, t in _messages(w)]
    assert texts.count("capped") == 2
    assert texts.count("free") == 4


def test_trigger_is_locked_for_two_seconds(task_copy) -> None:
    folder = _with_interaction(task_copy, "<triggers>" + _remote_trigger("t", "go", _message("x")) + "</triggers>")
    w = _world(folder)
    fired_at = []
    for t in (1.0, 1.5, 2.9, 3.05):
        _step_until(w, t)
        w.step(DriverControls(remote_triggers=("go",)))
        fired_at.append(w.t_s)
    triggers = [round(e.t_s, 6) for e in w.events.of_kind("trigger")]
    assert triggers == [round(fired_at[0], 6), round(fired_at[3], 6)]


def test_priority_orders_triggers_firing_in_the_same_step(task_copy) -> None:
    body = (
        "<triggers>"
        + _remote_trigger("low", "go", _message("low"), priority=1)
        + _remote_trigger("high", "go", _message("high"), priority=5)
        + _remote_trigger("mid", "go", _message("mid"), priority=3)
        + _remote_trigger("mid2", "go", _message("mid2"), priority=3)
        + "</triggers>"
    )
    w = _world(_with_interaction(task_copy, body))
    w.step(DriverControls(remote_triggers=("go",)))
    assert [t for _, t in _messages(w)] == ["high", "mid", "mid2", "low"]


def test_pause_stops_the_car_and_extends_the_lock(task_copy) -> None:
    pause = '<action id="pauseSimulation" delay="0" repeat="0"><parameter name="duration" value="1"/></action>'
    w = _world(_with_interaction(task_copy, "<triggers>" + _remote_trigger("p", "go", pause) + "</triggers>"))
    drive = DriverControls(accelerator=1.0)
    _step_until(w, 2.0, drive)
    w.step(DriverControls(accelerator=1.0, remote_triggers=("go",)))
    assert w.paused
    z = w.ego.state.z
    _step_until(w, w.t_s + 0.9, drive)
    assert w.paused and w.ego.state.z == z
    _step_until(w, w.t_s + 0.2, drive)
    assert not w.paused and w.ego.state.z != z
    # locked for 2 s + the 1 s pause: a press 2.5 s after firing is ignored, 3.1 s is not
    t0 = w.events.of_kind("trigger")[0].t_s
    _step_until(w, t0 + 2.5, drive)
    w.step(DriverControls(accelerator=1.0, remote_triggers=("go",)))
    assert len(w.events.of_kind("trigger")) == 1
    _step_until(w, t0 + 3.1, drive)
    w.step(DriverControls(accelerator=1.0, remote_triggers=("go",)))
    assert len(w.events.of_kind("trigger")) == 2


def test_key_reaction_timer_and_rearming_logs_a_miss(task_copy) -> None:
    start = '<action id="startReactionMeasurement" delay="0" repeat="0"/>'
    timer = (
        '<action id="setupKeyReactionTimer" delay="0" repeat="0"><parameter name="timerID" value="k"/>'
        '<parameter name="reactionGroup" value="keys"/><parameter name="correctReaction" value="KEY_A,JOY_3"/>'
        '<parameter name="failureReaction" value="B"/></action>'
    )
    body = "<triggers>" + _remote_trigger("s", "start", start) + _remote_trigger("k", "arm", timer) + "</triggers>"
    w = _world(_with_interaction(task_copy, body))
    w.step(DriverControls(remote_triggers=("start",)))
    w.step(DriverControls(remote_triggers=("arm",)))
    armed = w.t_s
    _step_until(w, armed + 0.5)
    w.step(DriverControls(keys=("a",)))  # lower-case jME name without KEY_ is the same key
    _step_until(w, armed + 3.0)
    w.step(DriverControls(remote_triggers=("arm",)))
    _step_until(w, w.t_s + 2.5)
    w.step(DriverControls(remote_triggers=("arm",)))  # re-armed while running: a miss first
    w.step(DriverControls(keys=("KEY_B",)))
    res = [(r.group, r.result, r.reaction_time_s) for r in w.triggers.reactions]
    assert res[0] == ("keys", 1, pytest.approx(0.5 + w.dt_s, abs=1e-9))
    assert res[1][:2] == ("keys", -2) and res[1][2] == 10.0
    assert res[2] == ("keys", -1, pytest.approx(w.dt_s, abs=1e-9))


def test_timer_before_start_of_measurement_is_ignored_with_a_warning(task_copy) -> None:
    timer = '<action id="setupKeyReactionTimer" delay="0" repeat="0"><parameter name="timerID" value="k"/></action>'
    w = _world(_with_interaction(task_copy, "<triggers>" + _remote_trigger("k", "arm", timer) + "</triggers>"))
    w.step(DriverControls(remote_triggers=("arm",)))
    assert not w.triggers.center.timers
    assert any("startReactionMeasurement" in e.params.get("message", "") for e in w.events.of_kind("warning"))


def test_get_set_state_replays_pending_delayed_actions(task_copy) -> None:
    body = "<triggers>" + _remote_trigger("t", "go", _message("a", delay=0.3) + _message("b", delay=1.0)) + "</triggers>"
    w = _world(_with_interaction(task_copy, body))
    w.step(DriverControls(remote_triggers=("go",)))
    _step_until(w, 0.5)
    snap = w.get_state()
    _step_until(w, 2.0)
    first = _messages(w)
    w.set_state(snap)
    _step_until(w, 2.0)
    assert _messages(w) == first and [t for _, t in first] == ["a", "b"]


# ---------------------------------------------------------------------- the corpus
def _corpus_tasks() -> list[Path]:
    return sorted(p.parent for p in CORPUS.glob("*/*/interaction.xml"))


@pytest.mark.parametrize("folder", _corpus_tasks(), ids=lambda p: p.name)
def test_every_corpus_trigger_runs_or_skips_unknown_actions(folder: Path, caplog) -> None:
    task = load_task(folder)
    w = World(task, WorldConfig(traffic=True))
    known_unknown = {a.name for a in task.interaction.all_actions() if action_spec(a.name) is None}
    with caplog.at_level(logging.WARNING):
        for i in range(len(w.triggers.triggers)):
            w.triggers.fire(i)
            w.run(0.5)
            if w.paused:
                w.triggers.resume("test")
    fired = [e.source for e in w.events.of_kind("trigger")]
    assert fired == [t.id for t in w.triggers.triggers]
    ran = {e.source for e in w.events.of_kind("action")}
    for t in w.triggers.triggers:
        for a in t.actions:
            assert a.name in ran or a.name in known_unknown, f"{t.id}: {a.name} neither ran nor was reported"
    warned = {e.source for e in w.events.of_kind("warning") if e.params.get("message") == "unknown action skipped"}
    assert warned == known_unknown & {a.name for t in w.triggers.triggers for a in t.actions}
    assert not w.events.of_kind("error"), [e.params for e in w.events.of_kind("error")]


def test_corpus_unknown_move_object_warns_once_and_is_skipped(task_copy, caplog) -> None:
    # Idealtest2 and the TVPT task carry `moveObject` (an action OpenDS does not have) only
    # inside XML comments; this copy makes Idealtest2's block live, as it once was.
    live = (
        '<activity ref="activity05"/><activity id="moveSign"><action id="moveObject" delay="0" repeat="1">'
        '<parameter name="id" value="RoadWorksSign01"/><parameter name="translationX" value="-81"/></action></activity>'
    )
    folder = task_copy("opends-cts/Idealtest2", "interaction.xml", '<activity ref="activity05"/>', live)
    w = World(load_task(folder), WorldConfig(traffic=True))
    assert any(a.name == "moveObject" for t in w.triggers.triggers for a in t.actions)
    with caplog.at_level(logging.WARNING):
        for _ in range(2):
            for i, t in enumerate(w.triggers.triggers):
                if any(a.name == "moveObject" for a in t.actions):
                    w.triggers.fire(i)
            w.run(2.5)
    unknown = [r for r in caplog.records if "unknown action 'moveObject'" in r.getMessage() and r.name.startswith("opends_gym.sim")]
    assert len(unknown) == 1  # at run time, once per name (the loader has warned once at load, with file and line)
    assert not [e for e in w.events.of_kind("action") if e.source == "moveObject"]


# ---------------------------------------------------------------------- ReactionTest
def _drive_reaction_test(w: World, plan: list[str], n_results: int) -> list[tuple[float, float, float, float]]:
    """Keep lane 2 at 60 km/h; on the k-th armed timer do plan[k]: 'react' (brake to
    below 40 km/h, or change to the target lane), 'brake' (tap the brake) or 'ignore'.
    Returns the (t, speed, x, brake) trace."""
    from opends_gym.control.controllers import speed_pedal, stanley_steering

    bands = {b.id: (b.x_min, b.x_max) for b in w.road.lanes}
    home = sum(bands["2"]) / 2
    target, action, k, cursor = home, "", -1, 0
    trace = []
    while len(w.triggers.reactions) < n_results and w.t_s < 300:
        for e in w.events.since(cursor):
            if e.kind == "reaction_timer" and e.params["armed"]:
                k += 1
                action = plan[k] + ":" + e.params["kind"]
                if action == "react:laneChange":
                    target = sum(bands[w.triggers.center.timers[e.source].target_lane]) / 2
            elif e.kind == "reaction":
                action, target = "", home
        cursor = len(w.events)
        s = w.ego.state
        steer = stanley_steering(s.yaw, 0.0, -s.x, -target, s.u)  # the road runs along -Z; left is -X
        gas, brake = max(0.0, speed_pedal(s.u, 60 / 3.6)), 0.0
        if action == "react:brake":
            gas, brake = 0.0, (1.0 if s.u > 35 / 3.6 else 0.0)
        elif action.startswith("brake:"):
            gas, brake, action = 0.0, 0.5, "done"
        w.step(DriverControls(steering=steer, accelerator=gas, brake=brake))
        trace.append((w.t_s, w.ego.state.u, w.ego.state.x, w.ego.inputs.brake))
    return trace


def test_reaction_test_scripted_drive_matches_expected_table(task_copy) -> None:
    # Trial 1 (the first lane change) forbids braking in this copy, to provoke a failure.
    folder = task_copy("opends-cts/ReactionTest", "interaction.xml", 'name="allowBrake" value="true"', 'name="allowBrake" value="false"')
    w = World(load_task(folder))
    plan = ["react", "brake", "ignore", "react", "react", "react"]
    trace = _drive_reaction_test(w, plan, len(plan))
    got = [(r.group, r.kind, r.result) for r in w.triggers.reactions]
    assert got == [
        ("Brake", "brake", 1),
        ("LaneChange", "laneChange", -1),
        ("Brake", "brake", -2),
        ("Brake", "brake", 1),
        ("Brake", "brake", 1),
        ("LaneChange", "laneChange", 1),
    ]
    dt = w.dt_s
    for r in w.triggers.reactions:
        during = [row for row in trace if r.start_t_s - 1e-9 <= row[0] <= r.t_s + 1e-9]
        if r.kind == "brake" and r.result == 1:
            # reaction time = first step at or below the 40 km/h target, minus the start
            first_slow = next(t for t, v, _, _ in during if v <= 40 / 3.6 + 1e-9)
            assert r.reaction_time_s == pytest.approx(first_slow - r.start_t_s, abs=1e-9)
            assert r.t_s == pytest.approx(first_slow + 2.0, abs=1e-9)  # held for holdSpeedFor
            assert 0 < r.extra["brake_onset_s"] <= r.reaction_time_s
        elif r.result == -1:
            first_brake = next(t for t, _, _, b in during if b > 0)
            assert r.reaction_time_s == pytest.approx(first_brake - r.start_t_s, abs=1e-9)
        elif r.result == -2:
            assert r.reaction_time_s == 10.0
            assert 7.0 < r.t_s - r.start_t_s <= 7.0 + dt + 1e-9  # taskCompletionAfterTime 7000 ms
        else:
            lane = w.road.lane_id_at
            target = next(lane(x) for _, _, x, _ in reversed(during))
            first_in = next(t for t, _, x, _ in during if lane(x) == target)
            assert r.reaction_time_s == pytest.approx(first_in - r.start_t_s, abs=1e-9)
            assert r.extra["steer_2deg_s"] <= r.extra["enter_lane_s"] <= r.reaction_time_s
        assert (r.reaction_time_s / dt) == pytest.approx(round(r.reaction_time_s / dt), abs=1e-6) or r.result == -2


def test_reaction_test_scripted_drive_is_deterministic() -> None:
    runs = []
    for _ in range(2):
        w = World("ReactionTest")
        _drive_reaction_test(w, ["react"] * 3, 3)
        runs.append([(r.result, r.reaction_time_s, r.t_s) for r in w.triggers.reactions])
    assert runs[0] == runs[1]


def test_contact_room_never_lets_the_car_skip_a_trigger_volume() -> None:
    """The room the contact test grants (how far the car may move, turning freely, before a
    trigger volume could touch it) is never too much: every pose within it touches nothing."""
    import math

    import numpy as np

    from opends_gym.sim.geometry2d import Obb

    w = _world(CORPUS / "opends-cts" / "ReactionTest")
    objects = w.objects
    volumes = [o for o in objects.objects if o.is_trigger]
    assert len(volumes) >= 20
    rng = np.random.default_rng(0)
    _, hx, hz = w._box
    roomy = 0
    for _ in range(400):
        anchor = volumes[int(rng.integers(len(volumes)))].position
        x, z = anchor[0] + rng.uniform(-40, 40), anchor[2] + rng.uniform(-40, 40)
        car = Obb(x, z, rng.uniform(-math.pi, math.pi), hx, hz)
        triggers, obstacles, room = objects.overlapping_with_room(car, -10.0, 10.0)
        if triggers or obstacles:
            assert room == 0.0
            continue
        roomy += room > 1.0
        for _ in range(20 if room > 0.0 else 0):  # anywhere inside the room, any heading: still nothing
            r, a = room * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
            moved = Obb(x + r * math.cos(a), z + r * math.sin(a), rng.uniform(-math.pi, math.pi), hx, hz)
            assert objects.overlapping(moved, -10.0, 10.0) == ([], []), (x, z, room, r)
    assert roomy > 100  # the room is not trivially zero: away from the volumes it is metres
