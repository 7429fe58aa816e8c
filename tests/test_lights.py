"""Traffic lights through the World: program phases, green on request, modes, traffic obeying them."""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task
from opends_gym.task.model_interaction import Interaction
from opends_gym.task.model_road import Intersection, Phase, Road, TrafficLightSpec
from opends_gym.task.model_scene import Model
from opends_gym.task.model_task import Pose
from opends_gym.task.model_traffic import TrafficVehicle, VehicleWayPoint

from .conftest import CORPUS

KMH = 1.0 / 3.6
FAR = Pose((3000.0, 0.0, 3000.0))


@functools.cache
def _base() -> DrivingTask:
    return load_task(CORPUS / "opends-cts" / "ConTReTask")


def _task(*intersections: Intersection, traffic: tuple = (), models: tuple = ()) -> DrivingTask:
    b = _base()
    return replace(
        b,
        scene=replace(b.scene, models=b.scene.models + tuple(models)),
        scenario=replace(b.scenario, traffic=traffic, road=Road(intersections=intersections)),
        interaction=Interaction(),
    )


def _world(task: DrivingTask, start: Pose = FAR) -> World:
    w = World(task, WorldConfig(), seed=0)
    w.reset(0, start=start)
    return w


def _light(lid: str, pos: int, initial: str = "red", **kw) -> TrafficLightSpec:
    return TrafficLightSpec(id=lid, phase_position=pos, initial_state=initial, **kw)


def _changes(w: World, light: str) -> list[tuple[float, str]]:
    return [(round(e.t_s, 4), e.params["state"]) for e in w.events.of_kind("traffic_light") if e.source == light]


def _run(w: World, seconds: float, controls: DriverControls | None = None) -> None:
    for _ in range(int(round(seconds / w.dt_s))):
        w.step(controls)


PROGRAM = Intersection(
    id="x",
    mode="program",
    phases=(Phase("1", 2.0, "Gr"), Phase("2", 1.0, "yr"), Phase("3", 3.0, "rg"), Phase("4", 1.0, "xy")),
    traffic_lights=(_light("A", 1), _light("B", 2)),
)


def test_program_mode_cycles_phases_with_their_durations() -> None:
    w = _world(_task(PROGRAM))
    lights = w.lights
    assert (lights.state_of("A"), lights.state_of("B")) == ("green", "red")  # the first phase from the start
    assert lights.remaining_s("A") == ("green", pytest.approx(2.0))
    assert lights.remaining_s("B") == ("red", pytest.approx(3.0))
    _run(w, 15.0)
    dt = w.dt_s
    a, b = _changes(w, "A"), _changes(w, "B")
    assert [s for _, s in a[:5]] == ["yellow", "red", "yellowred", "green", "yellow"]
    assert [t for t, _ in a[:5]] == pytest.approx([2.0, 3.0, 6.0, 7.0, 9.0], abs=dt + 1e-9)
    assert [s for _, s in b[:4]] == ["green", "yellow", "red", "green"]
    assert [t for t, _ in b[:4]] == pytest.approx([3.0, 6.0, 7.0, 10.0], abs=dt + 1e-9)
    assert all(e.params["mode"] == "program" and e.params["intersection"] == "x" for e in w.events.of_kind("traffic_light"))


def test_trigger_mode_serves_green_requests_after_the_required_lights_are_red() -> None:
    inter = Intersection(id="x", mode="trigger", traffic_lights=(_light("A", 1, "green"), _light("B", 2, requires_red="A")))
    w = _world(_task(inter))
    lights = w.lights
    _run(w, 2.0)  # entering trigger mode turns everything red: green -> yellow (1 s) -> red
    assert _changes(w, "A") == [(round(w.dt_s, 4), "yellow"), (round(w.dt_s + 1.0, 4), "red")]
    t0 = w.t_s
    assert lights.request_green("B")
    _run(w, 2.5)
    assert [s for _, s in _changes(w, "B")] == ["yellowred", "green"]
    assert [t - t0 for t, _ in _changes(w, "B")] == pytest.approx([w.dt_s + 1.0, w.dt_s + 2.0], abs=1e-3)
    assert lights.request_green("A")  # A has no requiresRed: every light of the intersection must be red first
    _run(w, 10.0)
    b = _changes(w, "B")
    assert [s for _, s in b] == ["yellowred", "green", "yellow", "red"]
    assert b[2][0] - b[1][0] == pytest.approx(3.0, abs=w.dt_s + 1e-9)  # B kept green for its 3 s first
    assert lights.state_of("A") == "green" and lights.state_of("B") == "red"
    assert lights.stop_mask.tolist() == [False, True]


def test_touching_a_light_trigger_model_requests_green_and_a_phase_trigger_reports() -> None:
    inter = Intersection(id="x", mode="trigger", traffic_lights=(_light("A", 1, trigger="pad"), _light("B", 2)))
    program = replace(PROGRAM, id="y", traffic_lights=(_light("C", 1, phase_trigger="pad"), _light("D", 2)))
    pad = Model(id="pad", ref="POI", translation_m=(0.0, 0.0, -500.0), visible=False)
    w = _world(_task(inter, program, models=(pad,)), start=Pose((0.0, 0.0, -500.0)))
    _run(w, 3.0, DriverControls(brake=1.0))
    assert "pad" in w.touching
    assert [e.source for e in w.events.of_kind("traffic_light_request")] == ["A"]  # once per contact
    assert w.lights.state_of("A") == "green"
    assert w.lights.state_of("B") == "red"
    reports = w.events.of_kind("traffic_light_report")
    assert [e.source for e in reports] == ["C"]  # phase triggers report in program mode, once per contact
    assert reports[0].params["state"] == "green" and reports[0].params["remaining_kind"] == "green"
    assert reports[0].params["remaining_s"] == pytest.approx(2.0 - reports[0].t_s, abs=2 * w.dt_s)


def test_blinking_off_and_external_modes() -> None:
    w = _world(_task(PROGRAM))
    lights = w.lights
    lights.set_mode("blinking")
    assert lights.state_of("A") == "off" and lights.mode_of("x") == "blinking"
    seen = []
    for _ in range(int(4.0 / w.dt_s)):
        w.step()
        seen.append(lights.state_of("B"))
    assert seen[0] == "yellow" and seen.count("yellow") == pytest.approx(seen.count("off"), abs=2)  # 1 s each
    assert seen[59] == "yellow" and seen[61] == "off"
    lights.set_mode("off")
    _run(w, 1.0)
    assert lights.state_of("A") == lights.state_of("B") == "off"
    assert not lights.set_external_state("A", "green")  # only in external mode
    lights.set_mode("external")
    assert lights.set_external_state("A", "green")
    _run(w, 5.0)
    assert lights.state_of("A") == "green"
    with pytest.raises(ValueError, match="mode"):
        lights.set_mode("disco")
    lights.toggle_mode()  # external -> blinking
    assert lights.mode_of("x") == "blinking"
    assert not lights.request_green("A")  # requests only count in trigger mode
    assert [e.params["mode"] for e in w.events.of_kind("traffic_light_mode")] == ["blinking", "off", "external", "blinking"]


def test_light_state_round_trips_bit_for_bit() -> None:
    inter = Intersection(id="x", mode="trigger", traffic_lights=(_light("A", 1, "green"), _light("B", 2)))
    w = _world(_task(inter, replace(PROGRAM, id="y", traffic_lights=(_light("C", 1), _light("D", 2)))))
    _run(w, 1.3)
    w.lights.request_green("B")
    _run(w, 0.7)
    snap = w.get_state()
    n = len(w.events)
    _run(w, 9.0)
    first = [(e.t_s, e.source, e.params["state"]) for e in w.events.since(n) if e.kind == "traffic_light"]
    w.set_state(snap)
    _run(w, 9.0)
    again = [(e.t_s, e.source, e.params["state"]) for e in w.events.since(n) if e.kind == "traffic_light"]
    assert first == again and len(first) > 5


def test_traffic_car_waits_at_a_program_light_and_passes_on_green() -> None:
    inter = Intersection(id="x", mode="program", phases=(Phase("r", 20.0, "r"), Phase("g", 20.0, "g")), traffic_lights=(_light("L", 1),))
    wps = tuple(
        VehicleWayPoint(id=f"w{k}", translation_m=(0.0, 0.0, -100.0 * k), speed_mps=50 * KMH, traffic_light="L" if k == 2 else None)
        for k in range(6)
    )
    car = TrafficVehicle(id="car", max_distance_from_path_m=5.0, start_way_point="w0", way_points=wps)
    w = _world(_task(inter, traffic=(car,)))
    tr = w.traffic
    _run(w, 19.0)
    assert tr.speed[0] == 0.0 and 0.0 < tr.positions[0, 2] + 200.0 < 8.5  # waiting just before the light
    _run(w, 8.0)
    assert w.lights.state_of("L") == "green" and tr.positions[0, 2] < -230.0


def test_request_green_and_report_actions_through_triggers(task_copy) -> None:
    folder: Path = task_copy("opends-cts/Idealtest2")
    act = (
        '<action id="requestGreenTrafficLight" delay="0" repeat="0"><parameter name="trafficLightID" value="TrafficLight.00_12"/></action>'
        '<action id="reportTrafficLight" delay="3" repeat="0"><parameter name="trafficLightID" value="TrafficLight.00_12"/>'
        '<parameter name="trafficLightState" value="green"/></action>'
    )
    (folder / "interaction.xml").write_text(
        '<?xml version="1.0"?>\n<interaction xmlns="http://opends.eu/drivingtask/interaction"><triggers>'
        f'<trigger id="t" priority="1"><activities><activity id="a">{act}</activity></activities>'
        "<condition>remote:go</condition></trigger></triggers></interaction>\n",
        encoding="utf-8",
    )
    w = World(load_task(folder), WorldConfig(), seed=0)
    _run(w, 0.5)
    w.step(DriverControls(remote_triggers=("go",)))
    _run(w, 4.0)
    reports = [e.params for e in w.events.of_kind("report") if e.params.get("what") == "traffic_light"]
    assert reports and reports[0]["state"] == "green" and reports[0]["condition_met"] is True
    assert np.isin(["TrafficLight.00_12"], [e.source for e in w.events.of_kind("traffic_light")]).all()
