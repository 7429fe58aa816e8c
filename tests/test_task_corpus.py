"""Every real OpenDS task of the corpus loads, with the contents the files describe."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from opends_gym.task import action_spec, load_task
from opends_gym.task.conditions import CameraWaypoint, CollideWith, OpenDrivePos, PressKey, Remote
from opends_gym.task.model_traffic import Pedestrian, TrafficVehicle

from .conftest import CORPUS, corpus_task_dirs


@pytest.mark.parametrize("folder", corpus_task_dirs(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_corpus_task_loads(folder: Path) -> None:
    task = load_task(folder)
    assert task.car_model.id == task.scenario.driver.car.ref
    assert len(task.scene.models) > 0


def test_reaction_test_contents() -> None:
    task = load_task(CORPUS / "opends-cts" / "ReactionTest")
    assert len(task.interaction.triggers) == 23
    lanes = task.scenario.road.lanes
    assert [lane.id for lane in lanes] == ["0", "1", "2", "3", "4"]
    assert [lane.x_min_m for lane in lanes] == [-9.25, -5.55, -1.85, 1.85, 5.55]
    assert lanes[-1].x_max_m == 9.25
    engine = task.scenario.driver.car.engine
    assert engine.max_speed_mps == pytest.approx(60 / 3.6)
    assert engine.min_speed_mps == pytest.approx(20 / 3.6)
    assert task.scenario.driver.car.brake.deceleration_free_wheel_mps2 == 2.0
    # 2500 road tiles share one id, plus the car, grass, triggers, signs
    assert sum(1 for m in task.scene.models if m.id == "road_5lane") == 2500
    assert task.start_pose.position_m == (0.0, 0.0, 24500.0)
    assert task.settings.reaction_groups.red == "Brake"
    assert task.settings.can_interface.max_steering_angle_rad == pytest.approx(math.pi)
    first = task.interaction.triggers[0]
    assert first.condition.items == (CollideWith("Exp_BLC_150_StartPosition_Trigger"),)


def test_reaction_test_action_parameters_are_typed_in_si_units() -> None:
    task = load_task(CORPUS / "opends-cts" / "ReactionTest")
    brake = next(a for a in task.interaction.all_actions() if a.name == "setupBrakeReactionTimer")
    spec = action_spec(brake.name)
    assert spec is not None
    values = {p.name: spec.by_name[p.name].codec.parse(p.value) for p in brake.params}
    assert values["startSpeed"] == pytest.approx(50 / 3.6)
    assert values["holdSpeedFor"] == pytest.approx(2.0)
    assert values["taskCompletionAfterTime"] == pytest.approx(7.0)
    assert brake.delay_s == pytest.approx(0.1)


def test_motorway_task_road_network() -> None:
    task = load_task(CORPUS / "opends-cts" / "MotorwayTask")
    vehicles = task.scenario.vehicles
    assert len(vehicles) == 41
    assert all(v.uses_road_network for v in vehicles)
    segments = task.scenario.road.segments
    assert segments is not None and len(segments.items) == 43
    a26 = next(s for s in segments.items if s.id == "Segment_A26")
    assert a26.jump and a26.speed_mps == pytest.approx(100 / 3.6)


def test_idealtest2_lights_and_ideal_track() -> None:
    task = load_task(CORPUS / "opends-cts" / "Idealtest2")
    assert len(task.scenario.road.intersections) == 8
    assert len(task.interaction.triggers) == 16
    track = task.scenario.driver.ideal_tracks[0]
    assert track.id == "idealTrack01" and track.road_width_m == 15.0
    assert all(p.ref for p in track.points)
    phase = task.scenario.road.intersections[0].phases[0]
    assert phase.duration_s > 0 and phase.state


def test_platoon_task_xml() -> None:
    task = load_task(CORPUS / "opends-cts" / "ThreeVehiclePlatooningTask")
    assert task.task is not None and task.task.three_vehicle_platoon is not None
    tvpt = task.task.three_vehicle_platoon
    assert (tvpt.leading_car.id, tvpt.leading_car.min_distance_m, tvpt.leading_car.max_distance_m) == ("car1", 20, 50)
    assert (tvpt.follower_car.min_distance_m, tvpt.follower_car.max_distance_m) == (5, 15)
    assert tvpt.lateral_tolerance is not None and (tvpt.lateral_tolerance.lower_bound_m, tvpt.lateral_tolerance.upper_bound_m) == (-2, 3)
    assert tvpt.max_reaction_time_s == pytest.approx(5.0)
    assert tvpt.logging is not None and tvpt.logging.logging_rate_hz == 20
    assert [b.id for b in task.task.distance_bars] == ["verticalBar", "horizontalBar"]
    assert len(task.interaction.triggers) == 17


def test_contre_conditions_and_steering_task() -> None:
    task = load_task(CORPUS / "opends-cts" / "ConTReTask")
    kinds = {type(c) for t in task.interaction.triggers for c in t.condition.items}
    assert Remote in kinds and CameraWaypoint in kinds
    st = task.task.steering_task if task.task else None
    assert st is not None and st.primary_task is not None
    assert st.primary_task.light_min_pause_s < st.primary_task.light_max_pause_s


def test_2023_structured_conditions_and_open_drive() -> None:
    task = load_task(CORPUS / "opends2023-annegretj" / "init_drive")
    conds = [c for t in task.interaction.triggers for c in t.condition.items]
    assert any(isinstance(c, PressKey) for c in conds)
    od = [c for c in conds if isinstance(c, OpenDrivePos)]
    assert od and od[0].road_id
    assert all(t.condition.structured for t in task.interaction.triggers)
    assert task.entry.open_drive == "road.xodr" and task.open_drive_path is not None and task.open_drive_path.is_file()
    assert len([t for t in task.scenario.traffic if isinstance(t, Pedestrian)]) == 6
    assert any("falsse" in w.message for w in task.warnings)


def test_gen_a_per_vehicle_waypoints() -> None:
    task = load_task(CORPUS / "opends35-breznak" / "Countryside")
    vehicles = [t for t in task.scenario.traffic if isinstance(t, TrafficVehicle)]
    assert len(vehicles) == 6
    for v in vehicles:
        assert len(v.way_points) >= 2 and not v.uses_road_network
        assert all(w.speed_mps is not None for w in v.way_points)
        assert v.curve_tension is not None
