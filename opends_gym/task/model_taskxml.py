"""task.xml: the ConTRe steering task and the Three-Vehicle Platoon Task (TVPT).

Why: OpenDS's classes for these two tasks are closed source, but their XML is public;
our ConTRe and platoon environments are specified from exactly these parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

from .bind import BOOL, FLOAT, INT, KMH, MS, STR, Choice, Custom, Struct, attr, elem, elems, source_line


def _attr_item(name: str) -> Custom[str]:
    """List item `<x name="value"/>` read as its attribute's string."""
    return Custom(
        lambda el, ctx: (el.get(name) or "").strip(),
        lambda el, v, ctx: el.set(name, v),
        lambda v: isinstance(v, str),
    )


@dataclass(frozen=True)
class BarObject:
    """ConTRe target or steering bar: scene model id, lateral speed and travel limits."""

    id: str = attr("id", required=True)
    speed: float = attr("speed", FLOAT, 0.5)
    max_left_m: float = attr("maxLeft", FLOAT, -1.0)
    max_right_m: float = attr("maxRight", FLOAT, 1.0)


@dataclass(frozen=True)
class Database:
    url: str = attr("url", STR, "")
    user: str = attr("user", STR, "")
    password: str = attr("password", STR, "")
    table: str = attr("table", STR, "")


@dataclass(frozen=True)
class PrimaryTask:
    """ConTRe's light reaction part: red -> brake, green -> accelerate."""

    start_point_ref: str = elem("startPoint/@ref", STR, "")
    end_point_ref: str = elem("endPoint/@ref", STR, "")
    is_peripheral_mode: bool = elem("isPeripheralMode", BOOL, False)
    icon_width_px: int | None = elem("iconWidth", INT)
    icon_height_px: int | None = elem("iconHeight", INT)
    icon_dist_from_left_frame_border_px: int | None = elem("iconDistFromLeftFrameBorder", INT)
    icon_dist_from_right_frame_border_px: int | None = elem("iconDistFromRightFrameBorder", INT)
    light_min_pause_s: float = elem("lightMinPause", MS, 2.0)
    light_max_pause_s: float = elem("lightMaxPause", MS, 6.0)
    light_duration_s: float = elem("lightDuration", MS, 1.0)
    blinking_threshold: float | None = elem("blinkingThreshold", FLOAT)
    min_blinking_duration_s: float | None = elem("minBlinkingDuration", MS)


@dataclass(frozen=True)
class SecondaryTask:
    start_point_ref: str = elem("startPoint/@ref", STR, "")
    end_point_ref: str = elem("endPoint/@ref", STR, "")
    wait_for_next_landmark_s: float | None = elem("waitForNextLandmark", MS)
    min_time_of_appearance_s: float | None = elem("minTimeOfAppearance", MS)
    max_visibility_distance_m: float | None = elem("maxVisibilityDistance", FLOAT)
    max_selection_distance_m: float | None = elem("maxSelectionDistance", FLOAT)
    max_angle_deg: float | None = elem("maxAngle", FLOAT)
    landmark_objects: tuple[str, ...] = elems("landmarkObjects", ("landmarkObject", _attr_item("id")))
    landmark_textures: tuple[str, ...] = elems("landmarkTextures", ("landmarkTexture", _attr_item("url")))
    distractor_textures: tuple[str, ...] = elems("distractorTextures", ("distractorTexture", _attr_item("url")))


@dataclass(frozen=True)
class SteeringTask:
    """ConTRe: track a moving target bar with the steering bar, react to the light above it."""

    start_point_ref: str = elem("startPoint/@ref", STR, "")
    end_point_ref: str = elem("endPoint/@ref", STR, "")
    steering_task_type: str = elem("steeringTaskType", STR, "")
    distance_to_objects_m: float = elem("distanceToObjects", FLOAT, 20.0)
    object_offset_m: float = elem("objectOffset", FLOAT, 0.0)
    height_offset_m: float = elem("heightOffset", FLOAT, 0.0)
    target_object: BarObject | None = elem("targetObject", Struct(BarObject))
    steering_object: BarObject | None = elem("steeringObject", Struct(BarObject))
    traffic_light_object_id: str | None = elem("trafficLightObject/@id", STR)
    pause_after_target_set_s: float | None = elem("pauseAfterTargetSet", MS)
    blinking_interval_s: float | None = elem("blinkingInterval", MS)
    database: Database | None = elem("database", Struct(Database))
    additional_table: bool | None = elem("additionalTable", BOOL)
    max_deviation_m: float | None = elem("maxDeviation", FLOAT)
    condition_name: str | None = elem("conditionName", STR)
    condition_number: int | None = elem("conditionNumber", INT)
    primary_task: PrimaryTask | None = elem("primaryTask", Struct(PrimaryTask))
    secondary_task: SecondaryTask | None = elem("secondaryTask", Struct(SecondaryTask))
    line: int = source_line()


@dataclass(frozen=True)
class DistanceBand:
    """A car's allowed distance range to the ego car (leading or follower)."""

    id: str = attr("id", required=True)
    min_distance_m: float = attr("minDistance", FLOAT, 0.0)
    max_distance_m: float = attr("maxDistance", FLOAT, 0.0)


@dataclass(frozen=True)
class SpeedReduction:
    target_speed_min_regular_mps: float = attr("targetSpeedMinRegular", KMH, 50.0 / 3.6)
    target_speed_max_regular_mps: float = attr("targetSpeedMaxRegular", KMH, 50.0 / 3.6)
    target_speed_min_emergency_mps: float = attr("targetSpeedMinEmergency", KMH, 0.0)
    target_speed_max_emergency_mps: float = attr("targetSpeedMaxEmergency", KMH, 0.0)
    min_speed_mps: float = attr("minSpeed", KMH, 20.0 / 3.6)
    duration_s: float = attr("duration", MS, 5.0)
    min_time_all_conditions_met_s: float = attr("minTimeAllConditionsMet", MS, 1.0)
    reset_on_reaction: bool = attr("resetOnReaction", BOOL, False)


@dataclass(frozen=True)
class Band:
    lower_bound_m: float = attr("lowerBound", FLOAT, 0.0)
    upper_bound_m: float = attr("upperBound", FLOAT, 0.0)


@dataclass(frozen=True)
class ShowText:
    top_px: int | None = attr("top", INT)
    bottom_px: int | None = attr("bottom", INT)
    left_px: int | None = attr("left", INT)
    right_px: int | None = attr("right", INT)
    scale: float | None = attr("scale", FLOAT)


@dataclass(frozen=True)
class DistanceIndicator:
    hide_at_position_z_m: float | None = elem("hideAtPosition/@z", FLOAT)
    show_text: ShowText | None = elem("showText", Struct(ShowText))
    longitudinal_bar_id: str | None = elem("showLongitudinalDistanceBar/@id", STR)
    lateral_bar_id: str | None = elem("showLateralDeviationBar/@id", STR)


@dataclass(frozen=True)
class PlatoonLogging:
    start_position_z_m: float | None = elem("startPosition/@z", FLOAT)
    shut_down_after_s: int | None = elem("startPosition/@shutDownAfterXSeconds", INT)
    end_position_z_m: float | None = elem("endPosition/@z", FLOAT)
    shut_down_when_reached: bool | None = elem("endPosition/@shutDownWhenReached", BOOL)
    logging_rate_hz: float = elem("loggingRate", FLOAT, 20.0)
    database: Database | None = elem("database", Struct(Database))
    condition_name: str | None = elem("condition/@name", STR)
    condition_number: int | None = elem("condition/@number", INT)
    report_template: str | None = elem("reportTemplate", STR)
    additional_table: bool | None = elem("additionalTable", BOOL)


@dataclass(frozen=True)
class ThreeVehiclePlatoon:
    leading_car: DistanceBand = elem("leadingCar", Struct(DistanceBand), required=True)
    follower_car: DistanceBand = elem("followerCar", Struct(DistanceBand), required=True)
    lane_offset_x_m: float | None = elem("laneOffset/@x", FLOAT)
    brake_light_min_duration_s: float | None = elem("brakeLight/@minDuration", MS)
    brake_light_reset_on_reaction: bool | None = elem("brakeLight/@resetOnReaction", BOOL)
    turn_signal_duration_s: float | None = elem("turnSignal/@duration", MS)
    turn_signal_reset_on_reaction: bool | None = elem("turnSignal/@resetOnReaction", BOOL)
    speed_reduction: SpeedReduction | None = elem("speedReduction", Struct(SpeedReduction))
    max_reaction_time_s: float = elem("maxReactionTime", MS, 5.0)
    longitudinal_tolerance: Band | None = elem("deviationTolerance/longitudinal", Struct(Band))
    lateral_tolerance: Band | None = elem("deviationTolerance/lateral", Struct(Band))
    distance_indicator: DistanceIndicator | None = elem("distanceIndicator", Struct(DistanceIndicator))
    logging: PlatoonLogging | None = elem("logging", Struct(PlatoonLogging))
    line: int = source_line()


BAR_SEGMENT_TYPES = ("red", "green", "redToGreen", "greenToRed")


@dataclass(frozen=True)
class BarSegment:
    name: str = attr("name", STR, "")
    type: str = attr("type", Choice(*BAR_SEGMENT_TYPES), "green")
    min_value: float = attr("minValue", FLOAT, 0.0)
    max_value: float = attr("maxValue", FLOAT, 0.0)


@dataclass(frozen=True)
class DistanceBar:
    id: str = attr("id", required=True)
    width_px: float = elem("width", FLOAT, 20.0, keep=True)
    height_px: float = elem("height", FLOAT, 200.0, keep=True)
    left_px: float = elem("left", FLOAT, 0.0, keep=True)
    bottom_px: float = elem("bottom", FLOAT, 0.0, keep=True)
    rotation_deg: float = elem("rotation", FLOAT, 0.0, keep=True)
    show_text: bool = elem("showText", BOOL, False, keep=True)
    segments: tuple[BarSegment, ...] = elems("segments", ("segment", Struct(BarSegment)))
    line: int = source_line()


@dataclass(frozen=True)
class TaskSpec:
    steering_task: SteeringTask | None = elem("steeringTask", Struct(SteeringTask))
    three_vehicle_platoon: ThreeVehiclePlatoon | None = elem("threeVehiclePlatoon", Struct(ThreeVehiclePlatoon))
    distance_bars: tuple[DistanceBar, ...] = elems("distanceBars", ("distanceBar", Struct(DistanceBar)))
