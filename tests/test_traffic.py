"""Traffic through the World and the TrafficManager's public interface: paths, network, obstacles, lights, actions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World
from opends_gym.task import DrivingTask
from opends_gym.task.model_task import Pose
from opends_gym.task.model_traffic import TrafficVehicle

from .conftest import CORPUS
from .traffic_helpers import KMH, gen_a_car, network, road_wp, run_for, segment, small_task, straight_car, world_for


# ---------------------------------------------------------------------- Gen A paths
def test_gen_a_car_follows_its_waypoints_and_reaches_their_speeds() -> None:
    w = world_for(CORPUS / "opends35-breznak" / "Countryside")
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
    w = world_for(small_task((gen_a_car("open", pts, [40] * 4), gen_a_car("loop", [(x + 200, z) for x, z in pts], [40] * 4, cyclic=True))))
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
        car = straight_car("c", extra={2: {"waiting_time_s": waiting_s}} if waiting_s else None)
        w = world_for(small_task((car,)))
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
        wps += [
            road_wp(f"A{k}", x, 0.0),
            road_wp(f"B{k}", x, -60.0),
            road_wp(f"L{k}", x - 15.0, -120.0),
            road_wp(f"R{k}", x + 15.0, -120.0),
        ]
        segs += [segment(f"S{k}", f"A{k}", f"B{k}", 60.0), segment(f"SL{k}", f"B{k}", f"L{k}", probability=0.7)]
        segs += [segment(f"SR{k}", f"B{k}", f"R{k}", probability=0.3)]
        cars.append(TrafficVehicle(id=f"car{k}", start_way_point=f"A{k}", segment_refs=tuple(p.format(k=k) for p in prefer)))
    return small_task(tuple(cars), network(wps, segs))


def _branches(w: World, lanes: int) -> list[str]:
    run_for(w, 9.0)
    return ["L" if w.traffic.positions[k, 0] < 40.0 * k else "R" for k in range(lanes)]


def test_gen_b_cars_pick_successors_by_probability_with_the_world_seed() -> None:
    lanes = 150
    task = _fork(lanes)
    a = _branches(world_for(task, seed=7), lanes)
    assert a == _branches(world_for(task, seed=7), lanes)  # same seed, same choices
    assert a != _branches(world_for(task, seed=8), lanes)
    share = a.count("L") / lanes
    assert abs(share - 0.7) < 0.12, share


def test_gen_b_preferred_segments_win_and_segment_speed_is_kept() -> None:
    w = world_for(_fork(3, prefer=("SR{k}",)))
    run_for(w, 5.0)
    assert np.allclose(w.traffic.speed, 60.0 * KMH, atol=1.5 * KMH)  # on S: 60 km/h
    assert _branches(w, 3) == ["R", "R", "R"]


def test_jump_segment_teleports_and_end_point_stops_for_good() -> None:
    wps = [road_wp("A", 0, 0), road_wp("B", 0, -80), road_wp("C", 100, 0), road_wp("D", 100, -80)]
    segs = [segment("AB", "A", "B"), segment("BA", "B", "A", jump=True), segment("CD", "C", "D")]
    w = world_for(
        small_task((TrafficVehicle(id="looper", start_way_point="A"), TrafficVehicle(id="ender", start_way_point="C")), network(wps, segs))
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


def _loop_network() -> DrivingTask:
    """A loop of segments with the cases a leg's end can bring: plain continuations (some only
    10 cm long, so several pass in one step), waypoint attributes, a wait, a fork drawn at
    random, a preferred branch, a jump and an end point."""
    wps = [
        road_wp("A", 0, 0, turn_signal="left", brake_light_on=True, head_light_intensity=0.5),
        road_wp("B", 0, -60, head_light_intensity=0.8),
        road_wp("B1", 0, -60.1, turn_signal="right"),
        road_wp("B2", 0, -60.2, turn_signal="off", brake_light_on=False),
        road_wp("C", 0, -120, waiting_time_s=1.5),
        road_wp("D", 40, -160),
        road_wp("E1", 80, -120),
        road_wp("E2", 80, -200),
        road_wp("F", 120, -60),
        road_wp("G", 160, 0),
        road_wp("H", 200, 0),
    ]
    segs = [segment("AB", "A", "B", 70.0), segment("BB1", "B", "B1"), segment("B1B2", "B1", "B2", 90.0), segment("B2C", "B2", "C"),
            segment("CD", "C", "D"), segment("DE1", "D", "E1", probability=0.5), segment("DE2", "D", "E2", probability=0.5),
            segment("E1F", "E1", "F"), segment("E2F", "E2", "F"), segment("FG", "F", "G"), segment("GA", "G", "A", jump=True),
            segment("GH", "G", "H", probability=0.5)]  # fmt: skip
    cars = tuple(TrafficVehicle(id=f"car{k}", start_way_point=wp, segment_refs=refs)
                 for k, (wp, refs) in enumerate([("A", ()), ("B", ()), ("C", ("DE2",)), ("E1", ()), ("F", ())]))  # fmt: skip
    return small_task(cars, network(wps, segs))


def test_network_legs_continued_by_the_kernel_match_the_python_leg_logic() -> None:
    """Cars whose next segment leaves nothing to chance are moved on by a compiled kernel; the
    rest (waits, forks, preferred segments, jumps, end points) by Python. Both must give the
    same traffic as Python alone, step for step."""
    task = _loop_network()
    fast, plain = world_for(task, seed=3), world_for(task, seed=3)
    plain.traffic._quiet_cars[:] = False  # every leg end through `LegLogic._arrive`
    assert fast.traffic._quiet_cars.sum() == 4  # (car2 prefers a segment)
    python_arrivals = []
    for w in (fast, plain):
        calls = []
        arrive = w.traffic._arrive
        w.traffic._arrive = lambda i, arrive=arrive, calls=calls: (calls.append(i), arrive(i))[1]  # type: ignore[method-assign]
        python_arrivals.append(calls)
    turn_seen, head_lights, jumps = set(), set(), 0
    for _ in range(int(60.0 / fast.dt_s)):
        before = fast.traffic.positions.copy()
        fast.step()
        plain.step()
        a, b = fast.traffic, plain.traffic
        for name in ("f", "i", "b", "pos", "end_xz"):
            assert np.array_equal(getattr(a.st, name), getattr(b.st, name), equal_nan=True), name
        assert np.array_equal(a.brake_light, b.brake_light) and np.array_equal(a.turn_signal, b.turn_signal)
        turn_seen.update(int(t) for t in a.turn_signal)
        head_lights.update(float(h) for h in a.st.head_light)
        jumps += int(np.sum(np.hypot(*(a.positions - before)[:, [0, 2]].T) > 20.0))
    assert len(python_arrivals[0]) < len(python_arrivals[1]) - 10  # the plain continuations needed no Python
    assert python_arrivals[0]  # ... and the others still reached it
    assert {0, 1, 2} <= turn_seen and 0.8 in head_lights and jumps > 0
    assert fast.traffic.st.halted.any()  # someone took GH to the end point


# ---------------------------------------------------------------------- obstacles and lights
def test_car_stops_behind_the_parked_ego_car_and_goes_on_when_it_leaves() -> None:
    w = world_for(small_task((straight_car("c"),)), ego_at=(0.0, 0.0, -300.0))
    hold = DriverControls(brake=1.0)
    run_for(w, 40.0, hold)
    tr = w.traffic
    gap = -(w.ego.state.z - tr.positions[0, 2])
    assert tr.speed[0] == 0.0 and 4.5 < gap < 12.0, gap
    assert w.collisions == 0
    w.reset_poses = {"away": Pose((50.0, 0.0, -300.0))}
    w.reset_car("away")
    run_for(w, 10.0, hold)
    assert tr.speed[0] > 30.0 * KMH and tr.positions[0, 2] < -320.0


def test_collision_between_ego_and_traffic_car_is_counted_by_the_world() -> None:
    w = world_for(small_task((straight_car("c"),)), ego_at=(0.0, 0.0, -200.0))
    w.traffic.set_speed_override("c", 0.0)
    run_for(w, 2.0, DriverControls(brake=1.0))
    w.reset_poses = {"behind": Pose((0.0, 0.0, w.traffic.positions[0, 2] + 30.0))}
    w.reset_car("behind")
    run_for(w, 8.0, DriverControls(accelerator=1.0))
    hits = w.events.of_kind("collision")
    assert w.collisions == 1 and [e.source for e in hits] == ["c"]


def test_car_stops_for_a_red_light_on_its_next_waypoint_and_goes_on_green() -> None:
    w = world_for(CORPUS / "opends-cts" / "Idealtest2")  # car2: 208 -> 209, whose light TrafficLight.00_12 is red
    tr, lights = w.traffic, w.lights
    run_for(w, 30.0)
    stop = np.array([-70.96055, -50.526424])
    i = tr.index_of("car2")
    assert lights.state_of("TrafficLight.00_12") == "red"
    assert tr.speed[i] == 0.0 and 0.0 < stop[0] - tr.positions[i, 0] < 8.5
    assert lights.request_green("TrafficLight.00_12")
    run_for(w, 1.5)
    assert tr.speed[i] == 0.0  # yellow-red is not yet green
    run_for(w, 6.0)
    assert lights.state_of("TrafficLight.00_12") == "green"
    assert tr.positions[i, 0] > stop[0] - 3.0 or tr.speed[i] > 1.0
    assert tr.turn_signal[i] == 2  # waypoint 209 switches the right indicator on


# ---------------------------------------------------------------------- actions
def test_move_traffic_action_teleports_to_a_waypoint() -> None:
    w = world_for(CORPUS / "opends35-breznak" / "ParisTraffic")
    run_for(w, 1.0)
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
    w = world_for(small_task((straight_car("lead", kmh=80.0),)))
    tr = w.traffic
    run_for(w, 15.0)
    assert abs(tr.speed[0] - 80.0 * KMH) < 1.5 * KMH and not tr.brake_light[0]
    tr.set_speed_override("lead", 30.0 * KMH, 6.0)
    v0 = float(tr.speed[0])
    run_for(w, 1.0)
    assert abs((v0 - tr.speed[0]) - 6.0) < 0.2 and tr.brake_light[0]
    run_for(w, 5.0)
    assert abs(tr.speed[0] - 30.0 * KMH) < 0.1 and not tr.brake_light[0]
    tr.set_speed_override("lead", 100.0 * KMH)  # replaces the path speed: faster than the path
    run_for(w, 12.0)
    assert abs(tr.speed[0] - 100.0 * KMH) < 1.5 * KMH
    tr.set_speed_override("lead", None)
    run_for(w, 10.0)
    assert abs(tr.speed[0] - 80.0 * KMH) < 1.5 * KMH
    tr.set_brake_light("lead", True)
    tr.set_turn_signal("lead", "left")
    assert tr.brake_light[0] and tr.turn_signal[0] == 1
    run_for(w, 0.5)
    assert tr.brake_light[0] and tr.turn_signal[0] == 1
    tr.set_brake_light("lead", None)
    tr.set_turn_signal("lead", None)
    assert not tr.brake_light[0] and tr.turn_signal[0] == 0
    with pytest.raises(ValueError, match="target_mps"):
        tr.set_speed_override("lead", math.nan)
    with pytest.raises(KeyError, match="ghost"):
        tr.set_brake_light("ghost", True)


def test_external_control_drives_the_car_off_its_path_until_released() -> None:
    w = world_for(small_task((straight_car("c"),)))
    tr = w.traffic
    run_for(w, 6.0)
    tr.set_external_control("c", 1.0, 0.0, 0.0)  # full lock left, no throttle
    run_for(w, 1.0)
    assert tr.positions[0, 0] < -1.0 and tr.yaw[0] > 0.3  # turned left (toward -X)
    tr.set_external_control("c", 0.0, 0.0, 1.0)
    run_for(w, 4.0)
    assert tr.speed[0] == 0.0 and tr.brake_light[0]
    tr.release_external_control("c")
    run_for(w, 20.0)
    assert abs(tr.positions[0, 0]) < 1.0 and tr.speed[0] > 40.0 * KMH


def test_lane_change_to_neighbour_segment_and_overtaking() -> None:
    wps = [
        road_wp("R0", 0, 0),
        road_wp("R1", 0, -2000),
        road_wp("L0", -3.5, 0),
        road_wp("L1", -3.5, -2000),
        road_wp("S0", 0, -60),
        road_wp("S1", 0, -2000.5),
    ]
    segs = [
        segment("right", "R0", "R1", 80, left_neighbor="left"),
        segment("left", "L0", "L1", 80, right_neighbor="right"),
        segment("slow", "S0", "S1", 80, left_neighbor="left"),
    ]
    w = world_for(small_task((TrafficVehicle(id="b", start_way_point="L0"),), network(wps, segs)))
    tr = w.traffic
    run_for(w, 8.0)
    assert abs(tr.positions[0, 0]) < 0.3  # right-hand traffic: back to the regular (right) lane when it is clear
    assert not tr.request_lane_change("b", 1)  # nothing right of the right lane
    assert tr.request_lane_change("b", -1)
    xs = []
    for _ in range(int(8 / w.dt_s)):
        w.step()
        xs.append(tr.positions[0, 0])
    assert min(xs) < -2.5 and tr.speed[0] > 70.0 * KMH
    # overtaking: a slow car ahead on the regular lane makes the follower use the passing lane
    w2 = world_for(
        small_task((TrafficVehicle(id="fast", start_way_point="R0"), TrafficVehicle(id="slow", start_way_point="S0")), network(wps, segs))
    )
    w2.traffic.set_speed_override("slow", 20.0 * KMH)
    xs = []
    for _ in range(int(25 / w2.dt_s)):
        w2.step()
        xs.append(w2.traffic.positions[0, 0])
    assert min(xs) < -3.0  # moved to the passing lane
    assert w2.traffic.positions[0, 2] < w2.traffic.positions[1, 2]  # and passed the slow car


def test_give_way_holds_a_car_while_prioritised_traffic_arrives() -> None:
    wps = [road_wp("A", 0, 0), road_wp("M", 0, -100), road_wp("E", 0, -400), road_wp("B", -100, -100)]

    def run(give_way: str | None) -> tuple[float, float]:
        segs = [segment("AM", "A", "M"), segment("ME", "M", "E"), segment("BM", "B", "M", give_way_to=give_way), segment("MX", "M", "E")]
        cars = (TrafficVehicle(id="main", start_way_point="A"), TrafficVehicle(id="side", start_way_point="B", segment_refs=("BM", "MX")))
        w = world_for(small_task(cars, network(wps, segs)))
        tr, closest = w.traffic, math.inf
        while tr.positions[0, 2] > -100.0:  # until the prioritised car reaches the merge point
            w.step()
            closest = min(closest, math.hypot(tr.positions[1, 0], tr.positions[1, 2] + 100.0))
        run_for(w, 10.0)
        return closest, float(tr.positions[1, 2])

    free, _ = run(None)
    held, later = run("AM")
    assert free < 3.0  # without the rule both arrive together
    assert held > 5.0  # with it, the side car waits before the merge point...
    assert later < -110.0  # ...and goes on afterwards
