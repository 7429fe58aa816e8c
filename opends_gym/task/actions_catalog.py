"""Every OpenDS interaction action: its parameters, their types, units and defaults.

Why: actions are resolved by name at run time in OpenDS, so a typo or a wrong value only
shows when the trigger fires. Declaring each action's parameters here lets the loader
check them up front (file, line, element) and hands the trigger core SI-typed values.
The table follows OpenDS's `InteractionMethods` (docs/opends-compatibility.md#trigger-actions).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .bind import BOOL, DEG, FLOAT, INT, KMH, MS, STR, Choice, Scalar

SECONDS = FLOAT


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: the file's name, its codec (with unit), the SI key and default."""

    name: str
    codec: Scalar[Any]
    key: str
    default: Any = None
    required: bool = False


@dataclass(frozen=True)
class ActionSpec:
    name: str
    params: tuple[ParamSpec, ...] = ()
    since: str = "all"
    doc: str = ""
    by_name: dict[str, ParamSpec] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        self.by_name.update({p.name: p for p in self.params})

    def defaults(self) -> dict[str, Any]:
        return {p.key: p.default for p in self.params}


def param(name: str, codec: Scalar[Any], key: str, default: Any = None, required: bool = False) -> ParamSpec:
    return ParamSpec(name, codec, key, default, required)


def _xyz(prefix: str, codec: Scalar[Any], suffix: str, key: str | None = None) -> tuple[ParamSpec, ...]:
    """Parameters prefixX/Y/Z; `key` lets an alias spelling share the SI key of another."""
    stem = key or _snake(prefix)
    return tuple(param(f"{prefix}{a}", codec, f"{stem}_{a.lower()}_{suffix}") for a in "XYZ")


def _snake(name: str) -> str:
    out = "".join("_" + c.lower() if c.isupper() else c for c in name)
    return out.lstrip("_")


_TIMER_COMMON = (
    param("timerID", STR, "timer_id", required=True),
    param("comment", STR, "comment", ""),
)
_LIMITS = (
    param("taskCompletionAfterTime", MS, "time_limit_s", 0.0),
    param("taskCompletionAfterDistance", FLOAT, "distance_limit_m", 0.0),
    param("failSound", STR, "fail_sound", ""),
    param("successSound", STR, "success_sound", ""),
)

# 2023 files repeat the action's own delay/repeat as parameters; they carry no meaning.
_LEGACY = (param("delay", FLOAT, "legacy_delay_s", None), param("maxRepeat", INT, "legacy_max_repeat", None))

_SPECS: tuple[ActionSpec, ...] = (
    ActionSpec(
        "sendMessage",
        (param("text", STR, "text", ""), param("duration", SECONDS, "duration_s", 1.0)),
        "2.x",
        "on-screen message; duration 0 = until replaced",
    ),
    ActionSpec("sendNumberToParallelPort", (param("number", INT, "number", 0), param("duration", MS, "duration_s", 0.1)), "3.5"),
    ActionSpec(
        "manipulateObject",
        (param("id", STR, "object_id", required=True),)
        + _xyz("translation", FLOAT, "m", "set_translation")
        + _xyz("rotation", DEG, "rad", "set_rotation")
        + _xyz("scale", FLOAT, "factor", "set_scale")
        + _xyz("setTranslation", FLOAT, "m")
        + _xyz("setRotation", DEG, "rad")
        + _xyz("setScale", FLOAT, "factor")
        + _xyz("addTranslation", FLOAT, "m")
        + _xyz("addRotation", DEG, "rad")
        + _xyz("addScale", FLOAT, "factor")
        + (param("visible", BOOL, "visible", None), param("collidable", BOOL, "collidable", None)),
    ),
    ActionSpec("manipulatePicture", (param("id", STR, "picture_id", required=True), param("visible", BOOL, "visible", True))),
    ActionSpec("pauseSimulation", (param("duration", SECONDS, "duration_s", 1.0),), doc="0 = until resumed"),
    ActionSpec("resumeSimulation"),
    ActionSpec("shutDownSimulation"),
    ActionSpec("startRecording", (param("track", INT, "track", None),)),
    ActionSpec("stopRecording"),
    ActionSpec("resetCar", (param("resetPointID", STR, "reset_point_id", required=True),)),
    ActionSpec(
        "moveTraffic",
        (
            param("trafficObjectID", STR, "traffic_object_id", required=True),
            param("wayPointID", STR, "way_point_id", None),
            param("engineOn", BOOL, "engine_on", None),
            param("enabled", BOOL, "enabled", None),
            param("startRoadID", STR, "start_road_id", None),
            param("startLaneID", INT, "start_lane_id", None),
            param("startS", FLOAT, "start_s_m", None),
            param("targetRoadID", STR, "target_road_id", None),
            param("targetLaneID", INT, "target_lane_id", None),
            param("targetS", FLOAT, "target_s_m", None),
        ),
    ),
    ActionSpec("setAutoPilot", (param("isEnabled", BOOL, "enabled", True),), "4.x"),
    ActionSpec(
        "startPresentationTask",
        (param("type", STR, "type", ""),)
        + _xyz("startPosition", FLOAT, "m")
        + _xyz("endPosition", FLOAT, "m")
        + _xyz("targetPosition", FLOAT, "m"),
    ),
    ActionSpec("setCurrentSpeedLimit", (param("speedLimit", KMH, "speed_limit_mps", 0.0),), doc="0 = no limit"),
    ActionSpec("setUpcomingSpeedLimit", (param("speedLimit", KMH, "speed_limit_mps", 0.0),), doc="0 = no limit"),
    ActionSpec("measureTimeUntilBrake", (param("triggerName", STR, "trigger_name", ""),)),
    ActionSpec(
        "measureTimeUntilSpeedChange",
        (param("triggerName", STR, "trigger_name", ""), param("speedChange", KMH, "speed_change_mps", 20.0 / 3.6)),
    ),
    ActionSpec("playSound", (param("soundID", STR, "sound_id", required=True),)),
    ActionSpec("pauseSound", (param("soundID", STR, "sound_id", required=True),), "2023"),
    ActionSpec("stopSound", (param("soundID", STR, "sound_id", required=True),), "2023"),
    ActionSpec("playMovie", (param("movieID", STR, "movie_id", ""),), "3.5"),
    ActionSpec("playNextMovie", (param("movieID", STR, "movie_id", ""),), "3.5"),
    ActionSpec("stopMovie", (param("movieID", STR, "movie_id", ""),), "3.5"),
    ActionSpec("requestGreenTrafficLight", (param("trafficLightID", STR, "traffic_light_id", required=True),)),
    ActionSpec("startReactionMeasurement"),
    ActionSpec(
        "setupKeyReactionTimer",
        _TIMER_COMMON
        + (
            param("reactionGroup", STR, "reaction_group", ""),
            param("correctReaction", STR, "correct_reaction", ""),
            param("failureReaction", STR, "failure_reaction", ""),
        ),
    ),
    ActionSpec(
        "setupReactionTimer",
        _TIMER_COMMON
        + (
            param("reactionGroup", STR, "reaction_group", ""),
            param("correctReaction", STR, "correct_reaction", ""),
            param("failureReaction", STR, "failure_reaction", ""),
        ),
        doc="deprecated alias of setupKeyReactionTimer",
    ),
    ActionSpec(
        "setupLaneChangeReactionTimer",
        _TIMER_COMMON
        + _LIMITS
        + (
            param("congruenceClass", STR, "reaction_group", ""),
            param("startLane", STR, "start_lane", required=True),
            param("targetLane", STR, "target_lane", required=True),
            param("minSteeringAngle", FLOAT, "min_steering_angle", 0.0),
            param("allowBrake", BOOL, "allow_brake", True),
            param("holdLaneFor", MS, "hold_lane_for_s", 2.0),
        ),
        "3.x",
    ),
    ActionSpec(
        "setupBrakeReactionTimer",
        _TIMER_COMMON
        + _LIMITS
        + (
            param("congruenceClass", STR, "reaction_group", ""),
            param("startSpeed", KMH, "start_speed_mps", 80.0 / 3.6),
            param("targetSpeed", KMH, "target_speed_mps", 60.0 / 3.6),
            param("mustPressBrakePedal", BOOL, "must_press_brake_pedal", True),
            param("allowLaneChange", BOOL, "allow_lane_change", True),
            param("holdSpeedFor", MS, "hold_speed_for_s", 2.0),
        ),
        "3.x",
    ),
    ActionSpec("setupSteeringReactionTimer", _TIMER_COMMON + (param("reactionGroup", STR, "reaction_group", ""),), "4.x"),
    ActionSpec("reportText", (param("text", STR, "text", ""), param("timestamp", BOOL, "timestamp", True)), "4.0"),
    ActionSpec(
        "reportSpeed", (param("type", Choice("greaterThan", "lessThan"), "type", "greaterThan"), param("speed", KMH, "speed_mps", 0.0))
    ),
    ActionSpec(
        "reportTrafficLight",
        (param("trafficLightID", STR, "traffic_light_id", ""), param("trafficLightState", STR, "traffic_light_state", "")),
    ),
    ActionSpec("openInstructionsScreen", (param("instructionID", STR, "instruction_id", ""),)),
    ActionSpec(
        "setCrosswind",
        (
            param("direction", Choice("left", "right"), "direction", "left"),
            param("force", FLOAT, "force", 0.0),
            param("duration", MS, "duration_s", 0.0),
        ),
        "3.5",
    ),
    ActionSpec(
        "setWeather",
        (
            param("snowingPercentage", FLOAT, "snowing_percent", None),
            param("rainingPercentage", FLOAT, "raining_percent", None),
            param("fogPercentage", FLOAT, "fog_percent", None),
        ),
        "4.x",
    ),
    ActionSpec("warningFrame", (param("interval", MS, "interval_s", 0.5), param("duration", MS, "duration_s", 0.0)), "4.x"),
    ActionSpec("setTVPTStimulus", (param("stimulusID", STR, "stimulus_id", required=True),), "3.x"),
    ActionSpec("setMotorwayTaskStimulus", (param("stimulusID", Choice("enter", "exit"), "stimulus_id", required=True),), "3.5"),
    ActionSpec(
        "writeToKnowledgeBase",
        (
            param("path", STR, "path", ""),
            param("propertyName", STR, "property_name", ""),
            param("propertyValue", STR, "property_value", ""),
            param("propertyType", STR, "property_type", "string"),
        ),
    ),
    ActionSpec("setupContreTask", (param("targetObjectSpeed", FLOAT, "target_object_speed", 0.5),), "3.x"),
    ActionSpec("setActiveReferenceObject", (param("id", STR, "object_id", ""),), "2023"),
    ActionSpec(
        "setODCarTargetLane",
        (param("trafficObjectID", STR, "traffic_object_id", required=True), param("laneID", INT, "lane_id", 0)) + _LEGACY,
        "2023",
    ),
    ActionSpec(
        "changeLaneODCar",
        (
            param("trafficObjectName", STR, "traffic_object_id", "null"),
            param("lanePos", Choice("Left", "Right"), "lane_pos", "Left"),
        )
        + _LEGACY,
        "2023",
        "trafficObjectName 'null' (or empty) means the driver's own car",
    ),
    ActionSpec(
        "changeVehicleLayout", (param("trafficObjectID", STR, "traffic_object_id", ""), param("layoutName", STR, "layout_name", "")), "2023"
    ),
    ActionSpec(
        "setOpenDSGauge",
        (
            param("autoPilotIndicator", STR, "auto_pilot_indicator", None),
            param("speedLimitIndicator", STR, "speed_limit_indicator", None),
            param("navigationImageId", STR, "navigation_image_id", None),
        ),
        "2023",
    ),
    ActionSpec(
        "detachGeometryByTexturePath",
        (param("comparisonType", STR, "comparison_type", ""), param("searchString", STR, "search_string", "")),
        "2023",
    ),
    ActionSpec(
        "addPlannerEvent",
        (
            param("name", STR, "name", ""),
            param("number", INT, "number", 0),
            param("duration", MS, "duration_s", 0.0),
            param("minTime", MS, "min_time_s", 0.0),
            param("maxTime", MS, "max_time_s", 0.0),
            param("visualDemand", FLOAT, "visual_demand", 0.0),
            param("auditoryDemand", FLOAT, "auditory_demand", 0.0),
            param("hapticDemand", FLOAT, "haptic_demand", 0.0),
            param("delayPenalty", FLOAT, "delay_penalty", 0.0),
            param("type", STR, "type", ""),
            param("value", STR, "value", ""),
        ),
        "2023",
    ),
    ActionSpec("setFuelConsumption", (param("burnedFuel", FLOAT, "burned_fuel_l", 0.0),), "2023"),
)

ACTIONS: dict[str, ActionSpec] = {s.name: s for s in _SPECS}


def action_spec(name: str) -> ActionSpec | None:
    """The spec of a known action, or None (OpenDS logs unknown actions and skips them)."""
    return ACTIONS.get(name)


def typed_args(spec: ActionSpec, params: Any) -> dict[str, Any]:
    """The action's parameters as SI-typed values under their keys, defaults filled in.

    `params` are the file's `Parameter`s (name, value). Values the codec rejects raise
    ValueError naming the parameter; the loader has already reported those with file and
    line, so at run time this only fails for tasks built in code.
    """
    out = spec.defaults()
    for p in params:
        ps = spec.by_name.get(p.name)
        if ps is None or not str(p.value).strip():
            continue
        try:
            out[ps.key] = ps.codec.parse(str(p.value))
        except (ValueError, TypeError):
            raise ValueError(f"parameter '{p.name}' of {spec.name}: '{p.value}' is not a valid {ps.codec.kind}") from None
    return out
