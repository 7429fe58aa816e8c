"""Traffic through the World: pedestrians, other OpenDS rules, corpus runs, determinism, OpenDRIVE cars, bad input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task
from opends_gym.task.model_interaction import Interaction
from opends_gym.task.model_task import Pose
from opends_gym.task.model_traffic import ODVehicle, Pedestrian, TrafficVehicle, VehicleWayPoint

from .conftest import CORPUS, corpus_task_dirs
from .traffic_helpers import FAR, KMH, network, road_wp, run_for, segment, small_task, straight_car, world_for


# ---------------------------------------------------------------------- other objects and rules
def test_pedestrians_walk_their_paths_and_disabled_ones_stand() -> None:
    pts = tuple(VehicleWayPoint(id=f"p{k}", translation_m=(10.0 * k, 0.0, 5.0), speed_mps=5.0 * KMH) for k in range(4))
    peds = (Pedestrian(id="walker", way_points=pts, start_way_point="p0"), Pedestrian(id="idle", way_points=pts, enabled=False))
    w = world_for(small_task(peds))
    tr = w.traffic
    start = tr.positions.copy()
    run_for(w, 10.0)
    assert abs(tr.positions[0, 0] - start[0, 0] - 5.0 * KMH * 10.0) < 0.1 and abs(tr.positions[0, 2] - 5.0) < 1e-6
    assert np.allclose(tr.positions[1], start[1]) and not tr.enabled[1]
    assert tr.half_extents[0, 1] < 0.5 and not tr.is_car[0]
    tr.set_enabled("idle", True)
    run_for(w, 2.0)
    assert tr.positions[1, 0] > start[1, 0] + 2.0
    # on the road network a pedestrian walks at the segment speed, capped by its maxSpeed
    net = network([road_wp("A", 0, 0), road_wp("B", 0, -100)], [segment("AB", "A", "B")])
    w = world_for(small_task((Pedestrian(id="p", start_way_point="A", max_speed_mps=6.0 * KMH),), net))
    run_for(w, 5.0)
    assert w.traffic.speed[0] == pytest.approx(6.0 * KMH) and w.traffic.positions[0, 2] == pytest.approx(-6.0 * KMH * 5.0, abs=0.05)


def test_reset_when_stuck_puts_an_object_back_on_its_start_waypoint() -> None:
    wps, segs = [road_wp("A", 0, 0), road_wp("B", 10, 0)], [segment("AB", "A", "B", 5.0)]
    w = world_for(small_task((Pedestrian(id="p", start_way_point="A", reset_when_stuck=True),), network(wps, segs)))
    xs = []
    for _ in range(int(30 / w.dt_s)):
        w.step()
        xs.append(w.traffic.positions[0, 0])
    resets = [e for e in w.events.of_kind("traffic") if e.params.get("what") == "reset_when_stuck"]
    assert resets and 7.2 + 6.0 < resets[0].t_s < 7.2 + 9.0  # 10 m at 5 km/h, then ~7 s standing
    assert max(xs) == pytest.approx(10.0) and np.any(np.diff(xs) < -5.0)


def test_never_faster_than_steering_car_and_engine_off() -> None:
    capped = replace(straight_car("capped"), never_faster_than_steering_car=True)
    w = world_for(small_task((capped, straight_car("free", x=20.0))))
    tr = w.traffic
    run_for(w, 5.0)
    assert tr.speed[0] == 0.0 and tr.speed[1] > 40.0 * KMH  # the ego car stands still
    v0 = float(tr.speed[1])
    tr.set_engine_on("free", False)  # rolls on against OpenDS's friction, 0.2 x decelerationFreeWheel
    run_for(w, 10.0)
    assert v0 - tr.speed[1] == pytest.approx(10.0 * 0.2 * 2.0, abs=0.05)


def test_lead_for_ego_reports_the_car_ahead_in_its_lane() -> None:
    w = world_for(small_task((straight_car("ahead"), straight_car("aside", x=6.0))), ego_at=(0.0, 0.0, 60.0))
    run_for(w, 4.0, DriverControls(brake=1.0))
    tr = w.traffic
    gap, v = w.traffic.lead_for_ego()
    expect = (w.ego.state.z - tr.positions[0, 2]) - tr.half_extents[0, 1] - 0.5 * w.ego.spec.length_m
    assert gap == pytest.approx(expect) and v == pytest.approx(tr.speed[0], rel=1e-6)


def test_every_corpus_task_with_traffic_runs_a_minute() -> None:
    dirs = [d for d in corpus_task_dirs() if load_task(d).scenario.traffic]
    assert {d.name for d in dirs} >= {
        "Countryside",
        "ParisTraffic",
        "MotorwayTask",
        "Idealtest2",
        "ThreeVehiclePlatooningTask",
        "init_drive",
    }
    for d in dirs:
        w = World(load_task(d), WorldConfig(), seed=3)
        tr = w.traffic
        fastest = np.zeros(len(tr.ids))
        for _ in range(60):
            w.run(1.0)
            fastest = np.maximum(fastest, tr.speed)
        assert tr is not None and len(tr.ids) == len(w.task.scenario.traffic), d
        assert np.all(np.isfinite(tr.positions)) and np.all(np.isfinite(tr.speed)), d
        assert not w.events.of_kind("error"), (d, [e.params for e in w.events.of_kind("error")])
        assert d.name == "init_drive" or fastest.max() > 5.0, d  # init_drive's pedestrians stand (speed 0 segments)


@pytest.mark.parametrize("name", ["opends-cts/MotorwayTask", "opends-cts/Idealtest2"])
def test_get_state_set_state_repeats_the_run_bit_for_bit(name: str) -> None:
    def trace(w: World) -> list[np.ndarray]:
        out = []
        for k in range(240):
            if k == 60 and w.lights is not None:
                w.lights.request_green("TrafficLight.00_12")
            w.step()
            out.append(np.concatenate([w.traffic.positions.ravel(), w.traffic.speed, w.traffic.yaw]))
        return out

    w = World(load_task(CORPUS / name), WorldConfig(), seed=11)
    w.run(3.0)
    snap = w.get_state()
    first = trace(w)
    w.set_state(snap)
    assert all(np.array_equal(a, b) for a, b in zip(first, trace(w)))
    twin = World(load_task(CORPUS / name), WorldConfig(), seed=11)
    twin.run(3.0)
    assert all(np.array_equal(a, b) for a, b in zip(first, trace(twin)))


# ---------------------------------------------------------------------- OpenDRIVE vehicles
def _od_task(*vehicles: ODVehicle) -> DrivingTask:
    t = load_task(CORPUS / "opends2023-annegretj" / "init_drive")
    return replace(t, scenario=replace(t.scenario, traffic=vehicles), interaction=Interaction())


def test_od_vehicle_follows_its_lane_and_changes_lane_on_request() -> None:
    w = world_for(_od_task(ODVehicle(id="od", start_road_id="s000", start_lane=-1, start_s_m=60.0, max_speed_mps=60 * KMH)))
    tr = w.traffic
    road, lane, s0 = tr.road_position_of("od")
    assert (road, lane) == ("s000", -1) and s0 == pytest.approx(60.0, abs=0.5)
    run_for(w, 10.0)
    road, lane, s1 = tr.road_position_of("od")
    assert lane == -1 and s1 > s0 + 100.0 and tr.speed[0] == pytest.approx(60 * KMH, abs=1.5 * KMH)
    assert not tr.request_lane_change("od", -1)  # left of lane -1 is the oncoming lane
    assert tr.request_lane_change("od", 1)
    run_for(w, 6.0)
    assert tr.road_position_of("od")[1] == -2


def test_od_vehicle_without_an_opendrive_map_stays_disabled_with_a_warning(caplog) -> None:
    w = world_for(small_task((ODVehicle(id="lost", start_road_id="1", start_lane=-1),)))
    assert not w.traffic.enabled[0]
    warned = [e for e in w.events.of_kind("warning") if e.source == "lost"]
    assert warned and "OpenDRIVE" in warned[0].params["message"]
    w.traffic.set_enabled("lost", True)
    assert not w.traffic.enabled[0]
    assert w.traffic.road_position_of("lost") is None


def test_unusable_paths_disable_their_object_with_a_warning_and_the_rest_runs() -> None:
    lonely = TrafficVehicle(id="lonely", way_points=(VehicleWayPoint(id="only", translation_m=(0.0, 0.0, 0.0), speed_mps=10.0),))
    stray = TrafficVehicle(id="stray", start_way_point="nowhere")
    dead_end = TrafficVehicle(id="dead_end", start_way_point="B")
    net = network([road_wp("A", 0, 0), road_wp("B", 0, -50)], [segment("AB", "A", "B")])
    w = world_for(small_task((lonely, stray, dead_end, straight_car("ok", x=30.0)), net))
    tr = w.traffic
    warned = {e.source: e.params["message"] for e in w.events.of_kind("warning")}
    assert {"lonely", "stray", "dead_end"} <= set(warned)
    assert "two waypoints" in warned["lonely"] and "nowhere" in warned["stray"] and "end point" in warned["dead_end"]
    assert tr.enabled.tolist() == [False, False, False, True]
    run_for(w, 3.0)
    assert tr.speed[3] > 5.0
    w.reset(1, start=Pose(FAR))
    assert len([e for e in w.events.of_kind("warning") if e.source == "lonely"]) == 1  # once per run
