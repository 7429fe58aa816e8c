"""Bundled platoon and brake-reaction tasks, generated in OpenDS format.

Why: both tests need a straight road with a leading car (and, for the platoon, a follower)
and stimuli fired by trigger boxes through `setTVPTStimulus`, exactly as OpenDS's own
TVPT task does (opends-cts/ThreeVehiclePlatooningTask). The `task.xml` values default to
that corpus task's: leading car 20-50 m, follower 5-15 m, longitudinal tolerance 20-35 m,
lateral -2..3 m, maximum reaction time 5000 ms, brake light and turn signal 2500 ms,
speed reduction to 50 km/h for 5000 ms. Traffic runs at 80 km/h on a two-lane road (lane
width 3.75 m); stimuli come every 250-400 m (seeded), in a shuffled balanced order.

`python -m opends_gym.envs.platoon_task tasks` rewrites tasks/ThreeVehiclePlatoon and
tasks/BrakeReaction.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..task.entry import EntryFile
from ..task.model_car import Car, CruiseControl, Engine
from ..task.model_interaction import Action, Activity, Interaction
from ..task.model_road import Lane, Road
from ..task.model_scenario import Driver, Scenario
from ..task.model_scene import Box, Scene, Sound
from ..task.model_settings import ReactionGroups, Settings
from ..task.model_task import DrivingTask
from ..task.model_taskxml import Band, DistanceBand, PlatoonLogging, SpeedReduction, TaskSpec, ThreeVehiclePlatoon
from ..task.model_traffic import TrafficVehicle, VehicleWayPoint
from .lct_task import _action, _model, _trigger

PLATOON_STIMULI = ("brakeLight", "leadingCarTurnSignal", "followerCarTurnSignal", "speedReduction", "emergencyBrake")
BRAKE_STIMULI = ("brakeLight", "emergencyBrake", "brakeSign")


@dataclass(frozen=True)
class PlatoonGeometry:
    lane_width_m: float = 3.75
    speed_kmh: float = 80.0
    stimuli: int = 10
    spacing_min_m: float = 250.0
    spacing_max_m: float = 400.0
    lead_in_m: float = 300.0
    lead_out_m: float = 300.0
    lead_gap_m: float = 30.0
    follower_gap_m: float = 10.0
    track_seed: int = 1
    follower: bool = True
    kinds: tuple[str, ...] = PLATOON_STIMULI


def stimulus_schedule(g: PlatoonGeometry) -> list[tuple[float, str]]:
    """(distance from the start, stimulus kind) in a balanced, seeded order."""
    rng = np.random.default_rng(g.track_seed)
    kinds = [g.kinds[i % len(g.kinds)] for i in range(g.stimuli)]
    rng.shuffle(kinds)
    d = g.lead_in_m
    out = []
    for kind in kinds:
        out.append((d, kind))
        d += float(rng.uniform(g.spacing_min_m, g.spacing_max_m))
    return out


def _vehicle(vid: str, x: float, z0: float, length_m: float, speed_mps: float) -> TrafficVehicle:
    points = tuple(
        VehicleWayPoint(id=f"{vid}_wp{k}", translation_m=(x, 0.0, z0 - k * 500.0), speed_mps=speed_mps)
        for k in range(int(length_m / 500.0) + 2)
    )
    return TrafficVehicle(
        id=vid,
        model_path="Models/Cars/drivingCars/CarBlue/Car.scene",
        mass_kg=800.0,
        acceleration_mps2=6.0,
        deceleration_brake_mps2=8.7,
        deceleration_free_wheel_mps2=2.0,
        min_distance_from_path_m=2.0,
        max_distance_from_path_m=4.0,
        curve_tension=0.05,
        path_is_cycle=False,
        path_is_visible=False,
        start_way_point=points[0].id,
        way_points=points,
    )


def build_platoon_task(g: PlatoonGeometry = PlatoonGeometry(), name: str = "threeVehiclePlatoon") -> DrivingTask:
    """The platoon (or, with `follower=False` and brake kinds, the brake reaction) task."""
    speed = g.speed_kmh / 3.6
    lane_x = g.lane_width_m / 2.0  # the ego drives in the right lane (+X when facing -Z)
    schedule = stimulus_schedule(g)
    length = schedule[-1][0] + g.lead_out_m
    models = [
        _model("driverCar", lane_x, 0.0, key="Models/Cars/drivingCars/CitroenC4/Car.j3o"),
        _model("road", 0.0, 0.0, key="Scenes/Highway/road_2lane.j3o"),
        _model("End_Trigger", 0.0, -length, ref="triggerBox", visible=False),
    ]
    activities = [
        Activity(id="Start", actions=(_action("startReactionMeasurement"), _action("startRecording", track="1"))),
        Activity(id="End", actions=(_action("stopRecording"), _action("pauseSimulation", duration="0"))),
    ]
    models.append(_model("Start_Trigger", 0.0, -5.0, ref="triggerBox", visible=False))
    triggers = [_trigger("Start_Trigger", "Start_Trigger", "Start"), _trigger("End_Trigger", "End_Trigger", "End")]
    for k, (d, kind) in enumerate(schedule):
        tag = f"Stimulus{k:02d}_{kind}"
        models.append(_model(f"{tag}_Trigger", 0.0, -d, ref="triggerBox", visible=False))
        if kind == "brakeSign":
            sign = f"{tag}_Sign"
            models.append(_model(sign, lane_x, -d - 60.0, key="Models/sign_panels/Brake/panel_sign.scene", visible=False))
            actions: tuple[Action, ...] = (
                _action("manipulateObject", id=sign, visible="true"),
                _action(
                    "setupBrakeReactionTimer",
                    timerID="brake",
                    congruenceClass="BrakeSign",
                    startSpeed=f"{g.speed_kmh - 15:g}",
                    targetSpeed=f"{g.speed_kmh - 30:g}",
                    mustPressBrakePedal="true",
                    taskCompletionAfterTime="7000",
                    taskCompletionAfterDistance="0",
                    holdSpeedFor="1000",
                    successSound="good",
                    failSound="fail",
                    comment=f"stimulus {k}: brake sign",
                ),
            )
        else:
            actions = (_action("setTVPTStimulus", stimulusID=kind),)
        activities.append(Activity(id=tag, actions=actions))
        triggers.append(_trigger(f"{tag}_Trigger", f"{tag}_Trigger", tag))
    traffic = [_vehicle("car1", lane_x, -g.lead_gap_m, length + 400.0, speed)]
    if g.follower:
        traffic.append(_vehicle("car2", lane_x, g.follower_gap_m, length + 400.0, speed))
    platoon = ThreeVehiclePlatoon(
        leading_car=DistanceBand("car1", 20.0, 50.0),
        follower_car=DistanceBand("car2" if g.follower else "car1", 5.0, 15.0),
        lane_offset_x_m=lane_x,
        brake_light_min_duration_s=2.5,
        brake_light_reset_on_reaction=True,
        turn_signal_duration_s=2.5,
        turn_signal_reset_on_reaction=True,
        speed_reduction=SpeedReduction(50 / 3.6, 50 / 3.6, 0.0, 0.0, 20 / 3.6, 5.0, 1.0, False),
        max_reaction_time_s=5.0,
        longitudinal_tolerance=Band(20.0, 35.0),
        lateral_tolerance=Band(-2.0, 3.0),
        logging=PlatoonLogging(start_position_z_m=-g.lead_in_m + 50.0, end_position_z_m=-length, logging_rate_hz=20.0),
    )
    car = Car(ref="driverCar", engine=Engine(max_speed_mps=130 / 3.6), cruise_control=CruiseControl(initial_speed_mps=speed))
    scenario = Scenario(
        driver=Driver(car=car),
        traffic=tuple(traffic),
        road=Road(lanes=(Lane("1", -g.lane_width_m, 0.0), Lane("2", 0.0, g.lane_width_m))),
    )
    scene = Scene(
        sounds=(Sound(id="good", key="Sounds/Effects/Beep.ogg"), Sound(id="fail", key="Sounds/Effects/Beep.ogg")),
        models=tuple(models),
        geometries=(Box(id="triggerBox", width_m=g.lane_width_m * 2 + 2.0, depth_m=0.5, height_m=2.0),),
    )
    settings = Settings(reaction_groups=ReactionGroups(red="BrakeSign", green="emergencyBrake", yellow="brakeLight"))
    entry = EntryFile(
        file_name=f"{name}.xml",
        scene="scene.xml",
        scenario="scenario.xml",
        interaction="interaction.xml",
        settings="settings.xml",
        task="task.xml",
    )
    return DrivingTask(
        name=name,
        entry=entry,
        scene=scene,
        scenario=scenario,
        interaction=Interaction(activities=tuple(activities), triggers=tuple(triggers)),
        settings=settings,
        task=TaskSpec(three_vehicle_platoon=platoon),
    )


def brake_geometry(track_seed: int = 1, stimuli: int = 9) -> PlatoonGeometry:
    return PlatoonGeometry(follower=False, kinds=BRAKE_STIMULI, track_seed=track_seed, stimuli=stimuli, speed_kmh=70.0)


def main(argv: list[str] | None = None) -> int:
    from ..task import save_task

    args = sys.argv[1:] if argv is None else argv
    out = Path(args[0] if args else "tasks")
    print(save_task(build_platoon_task(), out / "ThreeVehiclePlatoon"))
    print(save_task(build_platoon_task(brake_geometry(), name="brakeReaction"), out / "BrakeReaction"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
