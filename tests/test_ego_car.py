"""The driver's car through World + DriverControls: gears, engine, brakes, cruise control, caps, resets."""

from __future__ import annotations

from dataclasses import replace

import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import DrivingTask, load_task
from opends_gym.task.model_car import CruiseControl, Engine, Transmission
from opends_gym.task.model_interaction import Interaction


def road(**car_changes: object) -> DrivingTask:
    """The bundled LCT road with no triggers and a car with OpenDS defaults plus `car_changes`."""
    task = load_task("LaneChangeTest")
    changes: dict[str, object] = {"engine": Engine(), "cruise_control": CruiseControl(), **car_changes}
    car = replace(task.scenario.driver.car, **changes)  # type: ignore[arg-type]
    return replace(task, interaction=Interaction(), scenario=replace(task.scenario, driver=replace(task.scenario.driver, car=car)))


def world(task: DrivingTask, physics: str = "fast") -> World:
    return World(task, WorldConfig(physics=physics, traffic=False))


@pytest.mark.parametrize("physics", ["fast", "bullet"])
def test_full_throttle_accelerates_and_the_max_speed_caps(physics: str) -> None:
    w = world(road(engine=Engine(max_speed_mps=80 / 3.6)), physics)
    w.run(30.0, DriverControls(accelerator=1.0))
    assert 78.0 <= w.ego.state.u * 3.6 <= 80.5
    assert w.ego.powertrain.state.gear >= 3  # the automatic shifted up


def test_engine_off_gives_no_drive_and_restarts() -> None:
    w = world(road())
    w.step(DriverControls(engine_on=False))
    w.run(3.0, DriverControls(accelerator=1.0))
    assert w.ego.state.u == 0.0 and w.ego.powertrain.state.rpm < 100
    w.step(DriverControls(engine_on=True))
    w.run(3.0, DriverControls(accelerator=1.0))
    assert w.ego.state.u > 5.0


def test_manual_gearbox_reverse_and_neutral() -> None:
    w = world(road(transmission=Transmission(automatic=False)))
    w.step(DriverControls(gear=-1))
    w.run(3.0, DriverControls(accelerator=0.5))
    assert w.ego.state.u < -0.5  # backwards (reverse's power percentage 0.57 near standstill)
    w.step(DriverControls(gear=0, brake=1.0))
    w.run(2.0, DriverControls(brake=1.0))
    w.run(3.0, DriverControls(accelerator=1.0))
    assert abs(w.ego.state.u) < 0.1  # neutral: the engine revs, the car does not move
    assert w.ego.powertrain.state.rpm == pytest.approx(7500.0)
    w.step(DriverControls(gear=1))
    for _ in range(3):
        w.step(DriverControls(shift_up=True))
    assert w.ego.powertrain.state.gear == 4
    w.step(DriverControls(shift_down=True))
    assert w.ego.powertrain.state.gear == 3


def test_braking_from_100_kmh_uses_the_deceleration_brake() -> None:
    w = world(road(cruise_control=CruiseControl(initial_speed_mps=100 / 3.6)))
    z0 = w.ego.state.z
    steps = 0
    while w.ego.state.u > 0.0 and steps < 600:
        w.step(DriverControls(brake=1.0))
        steps += 1
    v0 = 100 / 3.6
    distance = abs(w.ego.state.z - z0)
    # OpenDS's brake impulse 0.004375 x 8.7 x mass per wheel per 0.01 s Bullet step is a
    # deceleration of 4 x 100 x 0.004375 x 8.7 = 15.2 m/s^2, plus the free-wheel drag
    # (0.2..1 x 4 x 100 x 0.004375 x 0.4 = 0.14..0.7 m/s^2)
    a_brake = 400 * 0.004375 * 8.7
    assert v0**2 / (2 * (a_brake + 400 * 0.004375 * 0.4)) < distance < v0**2 / (2 * a_brake)


def test_hand_brake_holds_the_car() -> None:
    w = world(road())
    w.run(2.0, DriverControls(accelerator=0.2, hand_brake=True))
    assert w.ego.state.u < 0.5


def test_cruise_control_holds_its_speed_and_the_brake_disengages_it() -> None:
    w = world(road(cruise_control=CruiseControl(initial_speed_mps=70 / 3.6)))
    w.run(20.0)
    assert w.ego.state.u * 3.6 == pytest.approx(70.0, abs=1.5)
    w.step(DriverControls(brake=0.3))
    assert not w.ego.cruise_active
    w.run(20.0)
    assert w.ego.state.u * 3.6 < 66.0  # coasting: free-wheel drag only


def test_min_speed_keeps_the_car_rolling_off_the_brake() -> None:
    w = world(road(engine=Engine(min_speed_mps=20 / 3.6)))
    w.run(15.0)
    assert w.ego.state.u * 3.6 >= 19.0
    w.run(5.0, DriverControls(brake=1.0))
    assert w.ego.state.u == 0.0  # the brake overrides minSpeed


@pytest.mark.parametrize("physics", ["fast", "bullet"])
def test_reset_to_a_reset_point(physics: str) -> None:
    task = load_task("ConTRe")
    w = World(task, WorldConfig(physics=physics, traffic=False))
    w.run(2.0, DriverControls(accelerator=1.0))
    pose = task.reset_poses()["reset2"]
    w.step(DriverControls(reset_to="reset2"))
    s = w.ego.state
    assert (s.x, s.z) == pytest.approx((pose.position_m[0], pose.position_m[2]), abs=0.05)
    assert s.yaw == pytest.approx(pose.yaw_rad, abs=1e-3) and abs(s.u) < 0.3
    assert any(e.kind == "reset" and e.source == "reset2" for e in w.events)
    w.step(DriverControls(reset_to="nowhere"))  # an unknown reset point is a logged warning, not a crash
    assert any(e.kind == "warning" and "nowhere" in str(e.params) for e in w.events)


def test_nan_controls_are_sanitised() -> None:
    w = world(road())
    w.step(DriverControls(steering=float("nan"), accelerator=float("nan"), brake=float("nan")))
    s = w.ego.state
    assert all(v == v for v in (s.x, s.z, s.u, s.yaw))


def test_fuel_is_used_while_driving() -> None:
    w = world(road())
    w.run(20.0, DriverControls(accelerator=0.7))
    st = w.ego.powertrain.state
    assert 0.0 < st.fuel_used_l < 0.5 and st.l_per_100km > 0.0 and st.fuel_left_l == pytest.approx(60.0 - st.fuel_used_l)
