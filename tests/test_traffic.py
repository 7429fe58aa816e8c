"""Traffic through the World and the TrafficManager's public interface (OpenDS FollowBox rules)."""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task
from opends_gym.task.model_interaction import Interaction
from opends_gym.task.model_road import Road, RoadWayPoint, RoadWayPoints, Segment, Segments
from opends_gym.task.model_task import Pose
from opends_gym.task.model_traffic import ODVehicle, Pedestrian, TrafficVehicle, VehicleWayPoint
from opends_gym.task.values import Rotation

from .conftest import CORPUS, corpus_task_dirs

FAR = (3000.0, 0.0, 3000.0)  # where the ego car waits when a test does not need it
KMH = 1.0 / 3.6


@functools.cache
def _base() -> DrivingTask:
    return load_task(CORPUS / "opends-cts" / "ConTReTask")


def _task(traffic: tuple = (), road: Road | None = None) -> DrivingTask:
    """A small task (ConTRe's scene, no triggers) with the given traffic and road network."""
    b = _base()
    return replace(b, scenario=replace(b.scenario, traffic=tuple(traffic), road=road or Road()), interaction=Interaction())


def _world(task: DrivingTask | Path, seed: int = 0, ego_at: tuple[float, float, float] | None = FAR, yaw_deg: float = 0.0) -> World:
    w = World(task if isinstance(task, DrivingTask) else load_task(task), WorldConfig(), seed=seed)
    if ego_at is not None:
        w.reset(seed, start=Pose(ego_at, Rotation.from_euler_deg(0.0, yaw_deg, 0.0)))
    return w


def _car(
    vid: str, points: list[tuple[float, float]], kmh: list[float], cyclic: bool = False, extra: dict[int, dict[str, Any]] | None = None
) -> TrafficVehicle:
    """A Gen A car on its own waypoints (x, z); `extra` maps a waypoint index to more fields."""
    wps = tuple(
        VehicleWayPoint(id=f"{vid}_wp{k}", translation_m=(x, 0.0, z), speed_mps=v * KMH, **(extra or {}).get(k, {}))
        for k, ((x, z), v) in enumerate(zip(points, kmh))
    )
    return TrafficVehicle(
        id=vid, max_distance_from_path_m=5.0, curve_tension=0.05, path_is_cycle=cyclic, start_way_point=wps[0].id, way_points=wps
    )


def _straight(vid: str, x: float = 0.0, kmh: float = 50.0, extra: dict[int, dict[str, Any]] | None = None) -> TrafficVehicle:
    length = 1000.0
    n = 11
    return _car(vid, [(x, -length * k / (n - 1)) for k in range(n)], [kmh] * n, extra=extra)


def _wp(wid: str, x: float, z: float, **kw) -> RoadWayPoint:
    return RoadWayPoint(id=wid, translation_m=(x, 0.0, z), **kw)


def _seg(sid: str, a: str, b: str, kmh: float = 50.0, **kw) -> Segment:
    return Segment(id=sid, from_wp=a, to_wp=b, speed_mps=kmh * KMH, **kw)


def _network(wps: list[RoadWayPoint], segs: list[Segment], **kw) -> Road:
    return Road(way_points=RoadWayPoints(points=tuple(wps)), segments=Segments(items=tuple(segs)), **kw)


def _run(w: World, seconds: float, controls: DriverControls | None = None) -> None:
    for _ in range(int(round(seconds / w.dt_s))):
        w.step(controls)


# ---------------------------------------------------------------------- Gen A paths
def test_gen_a_car_follows_its_waypoints_and_reaches_their_speeds() -> None:
    w = _world(CORPUS / "opends35-breznak" / "Countryside")
    tr = w.traffic
    i = tr.index_of("car1a")
    task_car = w.task.scenario.vehicles[i]
    wps = np.array([(p.translation_m[0], p.translation_m[2]) for p in task_car.way_points])
    speeds = np.array([p.speed_mps for p in task_car.way_points])
    seg_a, seg_b = wps[:-1], wps[1:] - wps[:-1]
    worst, at_wp = 0.0, dict[int, float]()
    for _ in range(int(60 / w.dt_s)):
        w.step()
        p = tr.positions[i, [0, 2]]
        t = np.clip(np.einsum("ij,ij->i", p - seg_a, seg_b) / np.einsum("ij,ij->i", seg_b, seg_b), 0, 1)
        worst = max(worst, float(np.min(np.hypot(*(seg_a + t[:, None] * seg_b - p).T))))
        k = int(np.argmin(np.hypot(*(wps - p).T)))
        if np.hypot(*(wps[k] - p)) < 1.5:
            at_wp.setdefault(k, float(tr.speed[i]))
    assert worst < 2.0  # the spline (tension 0.05) stays within a couple of metres of the polyline
    assert {5, 10, 14, 16, 18} <= set(at_wp)
    for k in (5, 10, 14, 16, 18):  # 70 km/h on the open road, 50 and 40 in the village
        assert abs(at_wp[k] - speeds[k]) < 3.0 * KMH, (k, at_wp[k] * 3.6, speeds[k] * 3.6)
    assert np.all(np.isfinite(tr.positions)) and w.collisions == 0


def test_open_path_restarts_at_waypoint_0_and_cyclic_path_closes() -> None:
    pts = [(0.0, 0.0), (0.0, -60.0), (60.0, -60.0), (60.0, 0.0)]
    w = _world(_task((_car("open", pts, [40] * 4), _car("loop", [(x + 200, z) for x, z in pts], [40] * 4, cyclic=True))))
    tr = w.traffic
    jumps: dict[str, list[tuple[float, np.ndarray]]] = {"open": [], "loop": []}
    prev = tr.positions[:, [0, 2]].copy()
    for _ in range(int(45 / w.dt_s)):
        w.step()
        now = tr.positions[:, [0, 2]]
        for vid in jumps:
            j = tr.index_of(vid)
            if np.hypot(*(now[j] - prev[j])) > 2.0:
                jumps[vid].append((w.t_s, now[j].copy()))
        prev = now.copy()
    assert jumps["loop"] == []  # the closed spline carries on through waypoint 0
    assert len(jumps["open"]) >= 1  # the open one is put back on its first waypoint
    assert np.allclose(jumps["open"][0][1], pts[0], atol=0.5)  # (one step of driving after the jump)
    loop = tr.index_of("loop")
    assert math.hypot(tr.positions[loop, 0] - 230.0, tr.positions[loop, 2] + 30.0) < 45.0  # still on its square


def test_waiting_time_pauses_the_car_at_its_waypoint() -> None:
    def arrival(waiting_s: float | None) -> tuple[float, float]:
        car = _straight("c", extra={2: {"waiting_time_s": waiting_s}} if waiting_s else None)
        w = _world(_task((car,)))
        tr, stopped, t_pass = w.traffic, 0.0, None
        while t_pass is None and w.t_s < 60.0:
            w.step()
            if tr.speed[0] < 0.01 and w.t_s > 2.0:
                stopped += w.dt_s
            if tr.positions[0, 2] < -400.0:
                t_pass = w.t_s
        assert t_pass is not None
        return t_pass, stopped

    plain, never = arrival(None)
    waited, stood = arrival(4.0)
    assert never == 0.0
    assert 1.0 < stood < 4.0  # stands while the 4 s run (the timer starts when the carrot gets there)
    assert 3.0 < waited - plain < 6.5


# ---------------------------------------------------------------------- Gen B network
def _fork(lanes: int, prefer: tuple[str, ...] = ()) -> DrivingTask:
    """`lanes` parallel start segments A->B, each forking at B into left (p 0.7) and right (p 0.3)."""
    wps, segs, cars = [], [], []
    for k in range(lanes):
        x = 40.0 * k
        wps += [_wp(f"A{k}", x, 0.0), _wp(f"B{k}", x, -60.0), _wp(f"L{k}", x - 15.0, -120.0), _wp(f"R{k}", x + 15.0, -120.0)]
        segs += [_seg(f"S{k}", f"A{k}", f"B{k}", 60.0), _seg(f"SL{k}", f"B{k}", f"L{k}", probability=0.7)]
        segs += [_seg(f"SR{k}", f"B{k}", f"R{k}", probability=0.3)]
        cars.append(TrafficVehicle(id=f"car{k}", start_way_point=f"A{k}", segment_refs=tuple(p.format(k=k) for p in prefer)))
    return _task(tuple(cars), _network(wps, segs))


def _branches(w: World, lanes: int) -> list[str]:
    _run(w, 9.0)
    return ["L" if w.traffic.positions[k, 0] < 40.0 * k else "R" for k in range(lanes)]


def test_gen_b_cars_pick_successors_by_probability_with_the_world_seed() -> None:
    lanes = 150
    task = _fork(lanes)
    a = _branches(_world(task, seed=7), lanes)
    assert a == _branches(_world(task, seed=7), lanes)  # same seed, same choices
    assert a != _branches(_world(task, seed=8), lanes)
    share = a.count("L") / lanes
    assert abs(share - 0.7) < 0.12, share


def test_gen_b_preferred_segments_win_and_segment_speed_is_kept() -> None:
    w = _world(_fork(3, prefer=("SR{k}",)))
    _run(w, 5.0)
    assert np.allclose(w.traffic.speed, 60.0 * KMH, atol=1.5 * KMH)  # on S: 60 km/h
    assert _branches(w, 3) == ["R", "R", "R"]


def test_jump_segment_teleports_and_end_point_stops_for_good() -> None:
    wps = [_wp("A", 0, 0), _wp("B", 0, -80), _wp("C", 100, 0), _wp("D", 100, -80)]
    segs = [_seg("AB", "A", "B"), _seg("BA", "B", "A", jump=True), _seg("CD", "C", "D")]
    w = _world(
        _task((TrafficVehicle(id="looper", start_way_point="A"), TrafficVehicle(id="ender", start_way_point="C")), _network(wps, segs))
    )
    tr = w.traffic
    zs = []
    for _ in range(int(30 / w.dt_s)):
        w.step()
        zs.append(tr.positions[0, 2])
    assert np.any(np.diff(zs) > 40.0)  # jumped back to A
    assert min(zs) > -80.5
    ender = tr.index_of("ender")
    assert tr.speed[ender] == 0.0 and abs(tr.positions[ender, 2] + 80.0) < 12.0


# ---------------------------------------------------------------------- obstacles and lights
def test_car_stops_behind_the_parked_ego_car_and_goes_on_when_it_leaves() -> None:
    w = _world(_task((_straight("c"),)), ego_at=(0.0, 0.0, -300.0))
    hold = DriverControls(brake=1.0)
    _run(w, 40.0, hold)
    tr = w.traffic
    gap = -(w.ego.state.z - tr.positions[0, 2])
    assert tr.speed[0] == 0.0 and 4.5 < gap < 12.0, gap
    assert w.collisions == 0
    w.reset_poses = {"away": Pose((50.0, 0.0, -300.0))}
    w.reset_car("away")
    _run(w, 10.0, hold)
    assert tr.speed[0] > 30.0 * KMH and tr.positions[0, 2] < -320.0


def test_collision_between_ego_and_traffic_car_is_counted_by_the_world() -> None:
    w = _world(_task((_straight("c"),)), ego_at=(0.0, 0.0, -200.0))
    w.traffic.set_speed_override("c", 0.0)
    _run(w, 2.0, DriverControls(brake=1.0))
    w.reset_poses = {"behind": Pose((0.0, 0.0, w.traffic.positions[0, 2] + 30.0))}
    w.reset_car("behind")
    _run(w, 8.0, DriverControls(accelerator=1.0))
    hits = w.events.of_kind("collision")
    assert w.collisions == 1 and [e.source for e in hits] == ["c"]


def test_car_stops_for_a_red_light_on_its_next_waypoint_and_goes_on_green() -> None:
    w = _world(CORPUS / "opends-cts" / "Idealtest2")  # car2: 208 -> 209, whose light TrafficLight.00_12 is red
    tr, lights = w.traffic, w.lights
    _run(w, 30.0)
    stop = np.array([-70.96055, -50.526424])
    i = tr.index_of("car2")
    assert lights.state_of("TrafficLight.00_12") == "red"
    assert tr.speed[i] == 0.0 and 0.0 < stop[0] - tr.positions[i, 0] < 8.5
    assert lights.request_green("TrafficLight.00_12")
    _run(w, 1.5)
    assert tr.speed[i] == 0.0  # yellow-red is not yet green
    _run(w, 6.0)
    assert lights.state_of("TrafficLight.00_12") == "green"
    assert tr.positions[i, 0] > stop[0] - 3.0 or tr.speed[i] > 1.0
    assert tr.turn_signal[i] == 2  # waypoint 209 switches the right indicator on


# ---------------------------------------------------------------------- actions
def test_move_traffic_action_teleports_to_a_waypoint() -> None:
    w = _world(CORPUS / "opends35-breznak" / "ParisTraffic")
    _run(w, 1.0)
    k = next(i for i, t in enumerate(w.triggers.triggers) if t.id == "collisionWithRedBox")
    w.triggers.fire(k)
    w.step()
    i = w.traffic.index_of("car1")
    assert np.allclose(w.traffic.positions[i, [0, 2]], (-72.77902, 4.9163313), atol=0.5)
    assert w.traffic.move_to_waypoint("car1", "WayPoint_2")
    assert np.allclose(w.traffic.positions[i, [0, 2]], (-140.60742, -69.83466), atol=1e-6)
    assert not w.traffic.move_to_waypoint("car1", "nowhere")
    assert any("nowhere" in e.params["message"] for e in w.events.of_kind("warning"))


def test_speed_override_brake_light_and_turn_signal() -> None:
    w = _world(_task((_straight("lead", kmh=80.0),)))
    tr = w.traffic
    _run(w, 15.0)
    assert abs(tr.speed[0] - 80.0 * KMH) < 1.5 * KMH and not tr.brake_light[0]
    tr.set_speed_override("lead", 30.0 * KMH, 6.0)
    v0 = float(tr.speed[0])
    _run(w, 1.0)
    assert abs((v0 - tr.speed[0]) - 6.0) < 0.2 and tr.brake_light[0]
    _run(w, 5.0)
    assert abs(tr.speed[0] - 30.0 * KMH) < 0.1 and not tr.brake_light[0]
    tr.set_speed_override("lead", 100.0 * KMH)  # replaces the path speed: faster than the path
    _run(w, 12.0)
    assert abs(tr.speed[0] - 100.0 * KMH) < 1.5 * KMH
    tr.set_speed_override("lead", None)
    _run(w, 10.0)
    assert abs(tr.speed[0] - 80.0 * KMH) < 1.5 * KMH
    tr.set_brake_light("lead", True)
    tr.set_turn_signal("lead", "left")
    assert tr.brake_light[0] and tr.turn_signal[0] == 1
    _run(w, 0.5)
    assert tr.brake_light[0] and tr.turn_signal[0] == 1
    tr.set_brake_light("lead", None)
    tr.set_turn_signal("lead", None)
    assert not tr.brake_light[0] and tr.turn_signal[0] == 0
    with pytest.raises(ValueError, match="target_mps"):
        tr.set_speed_override("lead", math.nan)
    with pytest.raises(KeyError, match="ghost"):
        tr.set_brake_light("ghost", True)


def test_external_control_drives_the_car_off_its_path_until_released() -> None:
    w = _world(_task((_straight("c"),)))
    tr = w.traffic
    _run(w, 6.0)
    tr.set_external_control("c", 1.0, 0.0, 0.0)  # full lock left, no throttle
    _run(w, 1.0)
    assert tr.positions[0, 0] < -1.0 and tr.yaw[0] > 0.3  # turned left (toward -X)
    tr.set_external_control("c", 0.0, 0.0, 1.0)
    _run(w, 4.0)
    assert tr.speed[0] == 0.0 and tr.brake_light[0]
    tr.release_external_control("c")
    _run(w, 20.0)
    assert abs(tr.positions[0, 0]) < 1.0 and tr.speed[0] > 40.0 * KMH


def test_lane_change_to_neighbour_segment_and_overtaking() -> None:
    wps = [_wp("R0", 0, 0), _wp("R1", 0, -2000), _wp("L0", -3.5, 0), _wp("L1", -3.5, -2000), _wp("S0", 0, -60), _wp("S1", 0, -2000.5)]
    segs = [
        _seg("right", "R0", "R1", 80, left_neighbor="left"),
        _seg("left", "L0", "L1", 80, right_neighbor="right"),
        _seg("slow", "S0", "S1", 80, left_neighbor="left"),
    ]
    w = _world(_task((TrafficVehicle(id="b", start_way_point="L0"),), _network(wps, segs)))
    tr = w.traffic
    _run(w, 8.0)
    assert abs(tr.positions[0, 0]) < 0.3  # right-hand traffic: back to the regular (right) lane when it is clear
    assert not tr.request_lane_change("b", 1)  # nothing right of the right lane
    assert tr.request_lane_change("b", -1)
    xs = []
    for _ in range(int(8 / w.dt_s)):
        w.step()
        xs.append(tr.positions[0, 0])
    assert min(xs) < -2.5 and tr.speed[0] > 70.0 * KMH
    # overtaking: a slow car ahead on the regular lane makes the follower use the passing lane
    w2 = _world(
        _task((TrafficVehicle(id="fast", start_way_point="R0"), TrafficVehicle(id="slow", start_way_point="S0")), _network(wps, segs))
    )
    w2.traffic.set_speed_override("slow", 20.0 * KMH)
    xs = []
    for _ in range(int(25 / w2.dt_s)):
        w2.step()
        xs.append(w2.traffic.positions[0, 0])
    assert min(xs) < -3.0  # moved to the passing lane
    assert w2.traffic.positions[0, 2] < w2.traffic.positions[1, 2]  # and passed the slow car


def test_give_way_holds_a_car_while_prioritised_traffic_arrives() -> None:
    wps = [_wp("A", 0, 0), _wp("M", 0, -100), _wp("E", 0, -400), _wp("B", -100, -100)]

    def run(give_way: str | None) -> tuple[float, float]:
        segs = [_seg("AM", "A", "M"), _seg("ME", "M", "E"), _seg("BM", "B", "M", give_way_to=give_way), _seg("MX", "M", "E")]
        cars = (TrafficVehicle(id="main", start_way_point="A"), TrafficVehicle(id="side", start_way_point="B", segment_refs=("BM", "MX")))
        w = _world(_task(cars, _network(wps, segs)))
        tr, closest = w.traffic, math.inf
        while tr.positions[0, 2] > -100.0:  # until the prioritised car reaches the merge point
            w.step()
            closest = min(closest, math.hypot(tr.positions[1, 0], tr.positions[1, 2] + 100.0))
        _run(w, 10.0)
        return closest, float(tr.positions[1, 2])

    free, _ = run(None)
    held, later = run("AM")
    assert free < 3.0  # without the rule both arrive together
    assert held > 5.0  # with it, the side car waits before the merge point...
    assert later < -110.0  # ...and goes on afterwards


# ---------------------------------------------------------------------- other objects and rules
def test_pedestrians_walk_their_paths_and_disabled_ones_stand() -> None:
    pts = tuple(VehicleWayPoint(id=f"p{k}", translation_m=(10.0 * k, 0.0, 5.0), speed_mps=5.0 * KMH) for k in range(4))
    peds = (Pedestrian(id="walker", way_points=pts, start_way_point="p0"), Pedestrian(id="idle", way_points=pts, enabled=False))
    w = _world(_task(peds))
    tr = w.traffic
    start = tr.positions.copy()
    _run(w, 10.0)
    assert abs(tr.positions[0, 0] - start[0, 0] - 5.0 * KMH * 10.0) < 0.1 and abs(tr.positions[0, 2] - 5.0) < 1e-6
    assert np.allclose(tr.positions[1], start[1]) and not tr.enabled[1]
    assert tr.half_extents[0, 1] < 0.5 and not tr.is_car[0]
    tr.set_enabled("idle", True)
    _run(w, 2.0)
    assert tr.positions[1, 0] > start[1, 0] + 2.0
    # on the road network a pedestrian walks at the segment speed, capped by its maxSpeed
    net = _network([_wp("A", 0, 0), _wp("B", 0, -100)], [_seg("AB", "A", "B")])
    w = _world(_task((Pedestrian(id="p", start_way_point="A", max_speed_mps=6.0 * KMH),), net))
    _run(w, 5.0)
    assert w.traffic.speed[0] == pytest.approx(6.0 * KMH) and w.traffic.positions[0, 2] == pytest.approx(-6.0 * KMH * 5.0, abs=0.05)


def test_reset_when_stuck_puts_an_object_back_on_its_start_waypoint() -> None:
    wps, segs = [_wp("A", 0, 0), _wp("B", 10, 0)], [_seg("AB", "A", "B", 5.0)]
    w = _world(_task((Pedestrian(id="p", start_way_point="A", reset_when_stuck=True),), _network(wps, segs)))
    xs = []
    for _ in range(int(30 / w.dt_s)):
        w.step()
        xs.append(w.traffic.positions[0, 0])
    resets = [e for e in w.events.of_kind("traffic") if e.params.get("what") == "reset_when_stuck"]
    assert resets and 7.2 + 6.0 < resets[0].t_s < 7.2 + 9.0  # 10 m at 5 km/h, then ~7 s standing
    assert max(xs) == pytest.approx(10.0) and np.any(np.diff(xs) < -5.0)


def test_never_faster_than_steering_car_and_engine_off() -> None:
    capped = replace(_straight("capped"), never_faster_than_steering_car=True)
    w = _world(_task((capped, _straight("free", x=20.0))))
    tr = w.traffic
    _run(w, 5.0)
    assert tr.speed[0] == 0.0 and tr.speed[1] > 40.0 * KMH  # the ego car stands still
    v0 = float(tr.speed[1])
    tr.set_engine_on("free", False)  # rolls on against OpenDS's friction, 0.2 x decelerationFreeWheel
    _run(w, 10.0)
    assert v0 - tr.speed[1] == pytest.approx(10.0 * 0.2 * 2.0, abs=0.05)


def test_lead_for_ego_reports_the_car_ahead_in_its_lane() -> None:
    w = _world(_task((_straight("ahead"), _straight("aside", x=6.0))), ego_at=(0.0, 0.0, 60.0))
    _run(w, 4.0, DriverControls(brake=1.0))
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
    w = _world(_od_task(ODVehicle(id="od", start_road_id="s000", start_lane=-1, start_s_m=60.0, max_speed_mps=60 * KMH)))
    tr = w.traffic
    road, lane, s0 = tr.road_position_of("od")
    assert (road, lane) == ("s000", -1) and s0 == pytest.approx(60.0, abs=0.5)
    _run(w, 10.0)
    road, lane, s1 = tr.road_position_of("od")
    assert lane == -1 and s1 > s0 + 100.0 and tr.speed[0] == pytest.approx(60 * KMH, abs=1.5 * KMH)
    assert not tr.request_lane_change("od", -1)  # left of lane -1 is the oncoming lane
    assert tr.request_lane_change("od", 1)
    _run(w, 6.0)
    assert tr.road_position_of("od")[1] == -2


def test_od_vehicle_without_an_opendrive_map_stays_disabled_with_a_warning(caplog) -> None:
    w = _world(_task((ODVehicle(id="lost", start_road_id="1", start_lane=-1),)))
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
    net = _network([_wp("A", 0, 0), _wp("B", 0, -50)], [_seg("AB", "A", "B")])
    w = _world(_task((lonely, stray, dead_end, _straight("ok", x=30.0)), net))
    tr = w.traffic
    warned = {e.source: e.params["message"] for e in w.events.of_kind("warning")}
    assert {"lonely", "stray", "dead_end"} <= set(warned)
    assert "two waypoints" in warned["lonely"] and "nowhere" in warned["stray"] and "end point" in warned["dead_end"]
    assert tr.enabled.tolist() == [False, False, False, True]
    _run(w, 3.0)
    assert tr.speed[3] > 5.0
    w.reset(1, start=Pose(FAR))
    assert len([e for e in w.events.of_kind("warning") if e.source == "lonely"]) == 1  # once per run
