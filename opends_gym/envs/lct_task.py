"""The ISO 26022-style Lane Change Test as an OpenDS driving task (generated, then bundled).

Why: OpenDS's LCT is closed source ("PRO"); we rebuild it in OpenDS's own format with the
free mechanisms the ReactionTest uses: hidden sign models revealed by `manipulateObject`
when the car touches a trigger box, and a `setupLaneChangeReactionTimer` per sign. The
bundled `tasks/LaneChangeTest` is this generator's default output
(`python -m opends_gym.envs.lct_task tasks/LaneChangeTest` rewrites it).

Track defaults and their sources (all configurable in `LctGeometry`):
* three lanes on a straight road, speed fixed at 60 km/h, 18 lane-change signs on a
  ~3000 m track, signs revealed 40 m ahead of the driver: the LCT as described by Mattes
  (2003, "The lane change task as a tool for driver distraction evaluation") and
  ISO 26022:2010's abstract;
* lane width 3.85 m and sign spacing 140-190 m (uniform, seeded): our choice, within the
  range of published LCT tracks; the ISO text itself was not available to us;
* basic normative model: lane change starting 30 m before the sign (10 m after it becomes
  visible, ~0.6 s at 60 km/h) with a gradient of one lane width per 40 m (2.4 s at
  60 km/h, a brisk but comfortable lane change; two lanes take 80 m): our documented
  default, since the ISO text was not available (see `metrics.lct`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..task.conditions import CollideWith, ConditionSet
from ..task.entry import EntryFile
from ..task.model_car import Car, CruiseControl, Engine
from ..task.model_interaction import Action, Activity, Interaction, Parameter, Trigger
from ..task.model_road import Lane, Road
from ..task.model_scenario import Driver, Scenario
from ..task.model_scene import Box, Model, Scene, Sound
from ..task.model_settings import ReactionGroups, Settings
from ..task.model_task import DrivingTask
from ..task.values import Rotation


@dataclass(frozen=True)
class LctGeometry:
    lanes: int = 3
    lane_width_m: float = 3.85
    speed_kmh: float = 60.0
    signs: int = 18
    spacing_min_m: float = 140.0
    spacing_max_m: float = 190.0
    visibility_m: float = 40.0
    lead_in_m: float = 200.0
    lead_out_m: float = 200.0
    start_z_m: float = 0.0
    track_seed: int = 1
    hold_lane_s: float = 1.0
    normative_start_before_sign_m: float = 30.0
    normative_length_per_lane_m: float = 40.0


@dataclass(frozen=True)
class LctSignSpec:
    index: int
    z_m: float  # world z of the sign pair
    from_lane: int  # lane index 0 = leftmost (smallest X)
    to_lane: int


def lane_bounds(g: LctGeometry) -> list[tuple[float, float]]:
    """(x_min, x_max) per lane, lane 0 leftmost when driving along -Z."""
    total = g.lanes * g.lane_width_m
    return [(-total / 2 + i * g.lane_width_m, -total / 2 + (i + 1) * g.lane_width_m) for i in range(g.lanes)]


def sign_sequence(g: LctGeometry) -> list[LctSignSpec]:
    """Seeded sign positions and lane instructions; every sign demands a lane change."""
    rng = np.random.default_rng(g.track_seed)
    lane = g.lanes // 2
    d = g.lead_in_m
    out = []
    for i in range(g.signs):
        target = int(rng.choice([k for k in range(g.lanes) if k != lane]))
        out.append(LctSignSpec(i, g.start_z_m - d, lane, target))
        lane = target
        d += float(rng.uniform(g.spacing_min_m, g.spacing_max_m))
    return out


def track_length_m(g: LctGeometry) -> float:
    signs = sign_sequence(g)
    return g.start_z_m - signs[-1].z_m + g.lead_out_m


def _model(mid: str, x: float, z: float, *, key: str = "", ref: str = "", visible: bool = True) -> Model:
    return Model(
        id=mid,
        key=key,
        ref=ref,
        visible=visible,
        collision_shape="none",
        rotation=Rotation.from_euler_deg(0.0, 0.0, 0.0),
        translation_m=(x, 0.0, z),
    )


def _action(name: str, delay_s: float = 0.0, repeat: int = 1, **params: str) -> Action:
    return Action(name=name, delay_s=delay_s, repeat=repeat, params=tuple(Parameter(k, v) for k, v in params.items()))


def _trigger(tid: str, model_id: str, *activity_ids: str) -> Trigger:
    return Trigger(
        id=tid, priority=1, activities=tuple(Activity(ref=a) for a in activity_ids), condition=ConditionSet((CollideWith(model_id),))
    )


def build_lct_task(g: LctGeometry = LctGeometry()) -> DrivingTask:
    """The LCT as a DrivingTask (what `tasks/LaneChangeTest` holds for the defaults)."""
    bounds = lane_bounds(g)
    signs = sign_sequence(g)
    end_z = signs[-1].z_m - g.lead_out_m + 20.0
    half_road = g.lanes * g.lane_width_m / 2
    models = [
        _model("driverCar", 0.0, g.start_z_m, key="Models/Cars/drivingCars/CitroenC4/Car.j3o"),
        _model("road", 0.0, g.start_z_m, key="Scenes/LaneChangeTest/road_3lane.j3o"),
        _model("LCT_Start_Trigger", 0.0, g.start_z_m - 5.0, ref="triggerBox", visible=False),
        _model("LCT_End_Trigger", 0.0, end_z, ref="triggerBox", visible=False),
    ]
    activities = [
        Activity(id="Start_startReactionMeasurement", actions=(_action("startReactionMeasurement"),)),
        Activity(id="Start_startRecording", actions=(_action("startRecording", track="1"),)),
        Activity(id="End_stopRecording", actions=(_action("stopRecording"),)),
        Activity(id="End_pause", actions=(_action("pauseSimulation", duration="0"),)),
    ]
    triggers = [
        _trigger("LCT_Start_Trigger", "LCT_Start_Trigger", "Start_startReactionMeasurement", "Start_startRecording"),
        _trigger("LCT_End_Trigger", "LCT_End_Trigger", "End_stopRecording", "End_pause"),
    ]
    for s in signs:
        tag = f"LCT_Sign{s.index:02d}"
        sign_key = f"Models/LaneChangeTest/sign_lane{s.to_lane + 1}.scene"
        models.append(_model(f"{tag}_Left", -half_road - 1.5, s.z_m, key=sign_key, visible=False))
        models.append(_model(f"{tag}_Right", half_road + 1.5, s.z_m, key=sign_key, visible=False))
        models.append(_model(f"{tag}_Trigger", 0.0, s.z_m + g.visibility_m, ref="triggerBox", visible=False))
        reveal = tuple(_action("manipulateObject", id=f"{tag}_{side}", visible="true") for side in ("Left", "Right"))
        timer = _action(
            "setupLaneChangeReactionTimer",
            timerID="lct",
            congruenceClass=f"LaneChange{'Left' if s.to_lane < s.from_lane else 'Right'}",
            startLane=str(s.from_lane + 1),
            targetLane=str(s.to_lane + 1),
            minSteeringAngle="0",
            taskCompletionAfterDistance=f"{g.spacing_min_m:g}",  # expires before the next sign arms the timer again
            taskCompletionAfterTime="0",
            allowBrake="true",
            holdLaneFor=f"{g.hold_lane_s * 1000:g}",
            successSound="good",
            failSound="fail",
            comment=f"sign {s.index}: lane {s.from_lane + 1} to {s.to_lane + 1}",
        )
        activities.append(Activity(id=f"{tag}_reveal", actions=(*reveal, timer)))
        triggers.append(_trigger(f"{tag}_Trigger", f"{tag}_Trigger", f"{tag}_reveal"))
    speed = g.speed_kmh / 3.6
    car = Car(
        ref="driverCar",
        engine=Engine(min_speed_mps=speed, max_speed_mps=speed),
        cruise_control=CruiseControl(initial_speed_mps=speed),
    )
    scenario = Scenario(
        driver=Driver(car=car),
        road=Road(lanes=tuple(Lane(str(i + 1), lo, hi) for i, (lo, hi) in enumerate(bounds))),
    )
    scene = Scene(
        sounds=(Sound(id="good", key="Sounds/Effects/Beep.ogg"), Sound(id="fail", key="Sounds/Effects/Beep.ogg")),
        models=tuple(models),
        geometries=(Box(id="triggerBox", width_m=2.0 * half_road + 2.0, depth_m=0.5, height_m=2.0),),  # the road and 1 m beside it
    )
    settings = Settings(reaction_groups=ReactionGroups(red="LaneChangeLeft", green="LaneChangeRight"))
    entry = EntryFile(
        file_name="laneChangeTest.xml", scene="scene.xml", scenario="scenario.xml", interaction="interaction.xml", settings="settings.xml"
    )
    return DrivingTask(
        name="laneChangeTest",
        entry=entry,
        scene=scene,
        scenario=scenario,
        interaction=Interaction(activities=tuple(activities), triggers=tuple(triggers)),
        settings=settings,
    )


def main(argv: list[str] | None = None) -> int:
    """Write the default LCT task: `python -m opends_gym.envs.lct_task OUT_FOLDER`."""
    from ..task import save_task

    args = sys.argv[1:] if argv is None else argv
    out = Path(args[0] if args else "tasks/LaneChangeTest")
    print(save_task(build_lct_task(), out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
