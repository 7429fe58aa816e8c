"""settings.xml: display, connections (CAN, HMI, ...), reaction groups and input mappings.

Why: the human mode reads its window layout, device mappings and CAN gateway from here,
and the analyzer colours reaction charts by `reactionMeasurement` groups. Blocks newer
than our reading of the XSDs are kept verbatim in `extra_blocks` so they save back.
"""

from __future__ import annotations

from dataclasses import dataclass

from .bind import BOOL, DEG, FLOAT, INT, RAW, STR, Choice, RawElement, Struct, attr, elem, elems, extras, source_line


@dataclass(frozen=True)
class Viewport:
    """A mirror or top view: fractions of the screen and optional view angles."""

    left: float | None = elem("viewPortLeft", FLOAT)
    right: float | None = elem("viewPortRight", FLOAT)
    bottom: float | None = elem("viewPortBottom", FLOAT)
    top: float | None = elem("viewPortTop", FLOAT)
    horizontal_angle_rad: float | None = elem("horizontalAngle", DEG)
    vertical_angle_rad: float | None = elem("verticalAngle", DEG)


@dataclass(frozen=True)
class TopView:
    car_pointing_up: bool | None = elem("carPointingUp", BOOL)
    left: float | None = elem("viewPortLeft", FLOAT)
    right: float | None = elem("viewPortRight", FLOAT)
    bottom: float | None = elem("viewPortBottom", FLOAT)
    top: float | None = elem("viewPortTop", FLOAT)
    vertical_distance_m: float | None = elem("verticalDistance", FLOAT)
    car_offset_m: float | None = elem("carOffset", FLOAT)


@dataclass(frozen=True)
class AnalogIndicators:
    left_px: int | None = elem("left", INT)
    right_px: int | None = elem("right", INT)
    bottom_px: int | None = elem("bottom", INT)
    top_px: int | None = elem("top", INT)
    scale: float | None = elem("scale", FLOAT)


@dataclass(frozen=True)
class XYZ:
    x: float | None = elem("x", FLOAT)
    y: float | None = elem("y", FLOAT)
    z: float | None = elem("z", FLOAT)


@dataclass(frozen=True)
class General:
    driver_name: str = elem("driverName", STR, "default driver")
    mirror_mode: str | None = elem("mirrorMode", Choice("off", "side_only", "back_only", "all"))
    show_stats: bool | None = elem("showStats", BOOL)
    pause_after_startup: bool | None = elem("pauseAfterStartup", BOOL)
    show_hood: bool | None = elem("showHood", BOOL)
    show_analog_indicators: bool | None = elem("showAnalogIndicators", BOOL)
    analog_indicators: AnalogIndicators | None = elem("analogIndicators", Struct(AnalogIndicators))
    show_digital_indicators: bool | None = elem("showDigitalIndicators", BOOL)
    show_fuel_consumption: bool | None = elem("showFuelConsumption", BOOL)
    number_of_screens: int = elem("numberOfScreens", INT, 1)
    angle_between_adjacent_cameras_rad: float | None = elem("angleBetweenAdjacentCameras", DEG)
    frustum_near_m: float | None = elem("frustumNear", FLOAT)
    frustum_far_m: float | None = elem("frustumFar", FLOAT)
    rearview_mirror: Viewport | None = elem("rearviewMirror", Struct(Viewport))
    left_mirror: Viewport | None = elem("leftMirror", Struct(Viewport))
    right_mirror: Viewport | None = elem("rightMirror", Struct(Viewport))
    top_view: TopView | None = elem("topView", Struct(TopView))
    outside_cam_position: XYZ | None = elem("outsideCamPosition", Struct(XYZ))
    capture_video: str | None = elem("captureVideo", STR)
    camera_mode: str | None = elem("cameraMode", Choice("ego", "chase", "static_back"))
    radar_camera: RawElement | None = elem("radarCamera", RAW)
    digital_map: RawElement | None = elem("digitalMap", RAW)
    use_fixed_simulation_step: bool | None = elem("useFixedSimulationStep", BOOL)
    fixed_simulation_step_s: float | None = elem("fixedSimulationStepSize", FLOAT)


@dataclass(frozen=True)
class Analyzer:
    file_name: str | None = elem("fileName", STR)
    suppress_pdf_popup: bool | None = elem("suppressPDFPopup", BOOL)


@dataclass(frozen=True)
class ObjectLocator:
    enable: bool = elem("enable", BOOL, False)
    file_name: str | None = elem("fileName", STR)


@dataclass(frozen=True)
class Connection:
    """An external connection block (HMI, knowledge manager, simphynity, multi-driver...)."""

    enable_connection: bool = elem("enableConnection", BOOL, False)
    ip: str | None = elem("ip", STR)
    port: int | None = elem("port", INT)
    update_rate_hz: float | None = elem("updateRate", FLOAT)


@dataclass(frozen=True)
class ExternalVisualization:
    enable_connection: bool = elem("enableConnection", BOOL, False)
    ip: str | None = elem("ip", STR)
    port: int | None = elem("port", INT)
    update_rate_hz: float | None = elem("updateRate", FLOAT)
    scaling_factor: float | None = elem("scalingFactor", FLOAT)
    send_pos_ori_as_one_string: bool | None = elem("sendPosOriAsOneString", BOOL)


@dataclass(frozen=True)
class CANInterface:
    """OpenDS's CAN gateway: OpenDS connects as a TCP client to ip:port."""

    enable_connection: bool = elem("enableConnection", BOOL, False)
    ip: str = elem("ip", STR, "192.168.0.2")
    port: int = elem("port", INT, 5678)
    update_rate_hz: float = elem("updateRate", FLOAT, 20.0)
    max_steering_angle_rad: float = elem("maxSteeringAngle", DEG, 270.0 * 3.141592653589793 / 180.0)


@dataclass(frozen=True)
class EyeOverlay:
    show: bool | None = elem("show", BOOL)
    color: str | None = elem("color", STR)
    scaling_factor: float | None = elem("scalingFactor", FLOAT)
    mode: str | None = elem("mode", STR)
    threshold: int | None = elem("threshold", INT)
    flashing_interval_ms: int | None = elem("flashingInterval", INT)


@dataclass(frozen=True)
class Eyetracker:
    enable_connection: bool = elem("enableConnection", BOOL, False)
    port: int | None = elem("port", INT)
    smoothing_factor: int | None = elem("smoothingFactor", INT)
    cross_hairs: EyeOverlay | None = elem("crossHairs", Struct(EyeOverlay))
    gaze_sphere: EyeOverlay | None = elem("gazeSphere", Struct(EyeOverlay))
    highlight_objects: EyeOverlay | None = elem("highlightObjects", Struct(EyeOverlay))
    warning_frame: EyeOverlay | None = elem("warningFrame", Struct(EyeOverlay))


@dataclass(frozen=True)
class OculusRift:
    is_attached: str | None = elem("isAttached", Choice("auto", "enabled", "disabled"))
    panel_pos_x: int | None = elem("panelPosX", INT)
    panel_pos_y: int | None = elem("panelPosY", INT)


@dataclass(frozen=True)
class Maritime:
    display_mode: str | None = elem("displayMode", Choice("Off", "Panel", "Compass", "MultiFunctionDisplay", "All"))


@dataclass(frozen=True)
class Codriver:
    enable_connection: bool = elem("enableConnection", BOOL, False)
    lib_name: str | None = elem("libName", STR)
    ip: str | None = elem("ip", STR)
    port: int | None = elem("port", INT)
    enable_log: bool | None = elem("enableLog", BOOL)
    log_type: int | None = elem("logType", INT)
    no_of_discarded_scenario_msgs: int | None = elem("noOfDiscardedScenarioMsgs", INT)
    sequential_msg_exchange: bool | None = elem("sequentialMsgExchange", BOOL)


@dataclass(frozen=True)
class Chrono:
    terrain_model_ref: str | None = elem("terrainModel/@ref", STR)


@dataclass(frozen=True)
class ServerBlock:
    """settingsControllerServer (and similar listen-only servers such as vsimrtiServer)."""

    start_server: bool = elem("startServer", BOOL, False)
    port: int = elem("port", INT, 1000)


REACTION_GROUP_COLOURS = ("red", "green", "yellow", "cyan", "blue", "magenta")


@dataclass(frozen=True)
class ReactionGroups:
    """Labels of the congruence classes, in the colour order of OpenDS's PDF report."""

    red: str = elem("groupRed", STR, "")
    green: str = elem("groupGreen", STR, "")
    yellow: str = elem("groupYellow", STR, "")
    cyan: str = elem("groupCyan", STR, "")
    blue: str = elem("groupBlue", STR, "")
    magenta: str = elem("groupMagenta", STR, "")

    def colour_of(self, group: str) -> str | None:
        for colour in REACTION_GROUP_COLOURS:
            if group and getattr(self, colour) == group:
                return colour
        return None


@dataclass(frozen=True)
class ScenarioMessage:
    send_to_codriver: bool | None = elem("sendToCodriver", BOOL)
    update_rate_hz: float | None = elem("updateRate", FLOAT)
    use_reference_lane: bool | None = elem("useReferenceLane", BOOL)
    show_message_box: bool | None = elem("showMessageBox", BOOL)
    print_status_msg: bool | None = elem("printStatusMsg", BOOL)
    print_csv_msg: bool | None = elem("printCSVMsg", BOOL)
    range_of_trajectory_forecast: int | None = elem("rangeOfTrajectoryForecast", INT)
    range_of_trajectory_backcast: int | None = elem("rangeOfTrajectoryBackcast", INT)
    range_of_speed_limit_forecast: int | None = elem("rangeOfSpeedLimitForecast", INT)
    range_of_intersection_forecast: int | None = elem("rangeOfIntersectionForecast", INT)
    range_of_traffic_light_forecast: int | None = elem("rangeOfTrafficLightForecast", INT)
    visualize_lane_markers: bool | None = elem("visualizeLaneMarkers", BOOL)
    visualize_heading_diff: bool | None = elem("visualizeHeadingDiff", BOOL)
    visualize_trajectory_forecast: bool | None = elem("visualizeTrajectoryForecast", BOOL)
    visualize_trajectory_backcast: bool | None = elem("visualizeTrajectoryBackcast", BOOL)
    vehicle_length_m: float | None = elem("vehicleLength", FLOAT)
    vehicle_width_m: float | None = elem("vehicleWidth", FLOAT)
    vehicle_bar_long_pos: float | None = elem("vehicleBarLongPos", FLOAT)
    requested_cruising_speed: float | None = elem("requestedCruisingSpeed", FLOAT)


@dataclass(frozen=True)
class AxisAssignment:
    """A joystick axis: controller, axis index, inversion and sensitivity."""

    controller_id: int = attr("controllerID", INT, 0)
    axis_id: int = attr("axisID", INT, 0)
    invert: bool = attr("invert", BOOL, False)
    sensitivity: float = attr("sensitivity", FLOAT, 1.0)


@dataclass(frozen=True)
class KeyAssignment:
    function: str = attr("function", required=True)
    key: str = attr("key", required=True)
    line: int = source_line()


@dataclass(frozen=True)
class Joystick:
    dump_joystick_list: bool | None = elem("dumpJoystickList", BOOL)
    steering: AxisAssignment | None = elem("steering", Struct(AxisAssignment))
    combined_pedals: AxisAssignment | None = elem("combinedPedals", Struct(AxisAssignment))
    accelerator: AxisAssignment | None = elem("accelerator", Struct(AxisAssignment))
    brake: AxisAssignment | None = elem("brake", Struct(AxisAssignment))
    clutch: AxisAssignment | None = elem("clutch", Struct(AxisAssignment))
    key_assignments: tuple[KeyAssignment, ...] = elems("keyAssignments", ("keyAssignment", Struct(KeyAssignment)))
    enable_force_feedback: bool | None = elem("enableForceFeedback", BOOL)
    spring_force: float | None = elem("springForce", FLOAT)
    damper_force: float | None = elem("damperForce", FLOAT)
    enable_spring_force: bool | None = elem("enableSpringForce", BOOL)
    enable_damper_force: bool | None = elem("enableDamperForce", BOOL)
    enable_surface_effect: bool | None = elem("enableSurfaceEffect", BOOL)
    enable_collision_effect: bool | None = elem("enableCollisionEffect", BOOL)
    enable_airborne_effect: bool | None = elem("enableAirborneEffect", BOOL)
    enable_ghost_wheel: bool | None = elem("enableGhostWheel", BOOL)


@dataclass(frozen=True)
class Keyboard:
    key_assignments: tuple[KeyAssignment, ...] = elems("keyAssignments", ("keyAssignment", Struct(KeyAssignment)))


@dataclass(frozen=True)
class Mouse:
    scroll_sensitivity_factor: float | None = elem("scrollSensitivityFactor", FLOAT)
    min_scroll_zoom: float | None = elem("minScrollZoom", FLOAT)
    max_scroll_zoom: float | None = elem("maxScrollZoom", FLOAT)


@dataclass(frozen=True)
class Controllers:
    joystick: Joystick | None = elem("joystick", Struct(Joystick))
    keyboard: Keyboard | None = elem("keyboard", Struct(Keyboard))
    mouse: Mouse | None = elem("mouse", Struct(Mouse))


@dataclass(frozen=True)
class OpenDriveSettings:
    visualize_roads: bool | None = elem("visualizeRoads", BOOL)
    visualize_geometries: bool | None = elem("visualizeGeometries", BOOL)
    visualize_geometry_details: bool | None = elem("visualizeGeometryDetails", BOOL)
    interpolation_step_size_m: float | None = elem("interpolationStepSize", FLOAT)
    ignore_non_driving_lanes: bool | None = elem("ignoreNonDrivingLanes", BOOL)
    project_onto_terrain: bool | None = elem("projectOntoTerrain", BOOL)
    projection_offset_m: float | None = elem("projectionOffset", FLOAT)
    add_to_physics_engine: bool | None = elem("addToPhysicsEngine", BOOL)


@dataclass(frozen=True)
class EventPlanner:
    mode: str | None = elem("mode", STR)
    timeline_start: float | None = elem("timeline/start", FLOAT)
    timeline_end: float | None = elem("timeline/end", FLOAT)


@dataclass(frozen=True)
class AmazonPolly:
    enable_connection: bool = elem("enableConnection", BOOL, False)
    access_key: str | None = elem("accessKey", STR)
    secret_key: str | None = elem("secretKey", STR)
    region: str | None = elem("region", STR)
    voice: str | None = elem("voice", STR)


@dataclass(frozen=True)
class Settings:
    general: General = elem("general", Struct(General), General())
    analyzer: Analyzer | None = elem("analyzer", Struct(Analyzer))
    object_locator: ObjectLocator | None = elem("objectLocator", Struct(ObjectLocator))
    hmi: Connection | None = elem("HMI", Struct(Connection))
    external_visualization: ExternalVisualization | None = elem("externalVisualization", Struct(ExternalVisualization))
    knowledge_manager: Connection | None = elem("knowledgeManager", Struct(Connection))
    simphynity: Connection | None = elem("simphynity", Struct(Connection))
    can_interface: CANInterface = elem("CANInterface", Struct(CANInterface), CANInterface())
    multi_driver: Connection | None = elem("multiDriver", Struct(Connection))
    eyetracker: Eyetracker | None = elem("eyetracker", Struct(Eyetracker))
    oculus_rift: OculusRift | None = elem("oculusRift", Struct(OculusRift))
    maritime: Maritime | None = elem("maritime", Struct(Maritime))
    codriver: Codriver | None = elem("codriver", Struct(Codriver))
    chrono: Chrono | None = elem("chrono", Struct(Chrono))
    settings_controller_server: ServerBlock = elem("settingsControllerServer", Struct(ServerBlock), ServerBlock())
    reaction_groups: ReactionGroups = elem("reactionMeasurement", Struct(ReactionGroups), ReactionGroups())
    scenario_message: ScenarioMessage | None = elem("scenarioMessage", Struct(ScenarioMessage))
    controllers: Controllers = elem("controllers", Struct(Controllers), Controllers())
    open_drive: OpenDriveSettings | None = elem("openDrive", Struct(OpenDriveSettings))
    event_planner: EventPlanner | None = elem("eventPlanner", Struct(EventPlanner))
    amazon_polly: AmazonPolly | None = elem("amazonPolly", Struct(AmazonPolly))
    vsimrti_server: ServerBlock | None = elem("vsimrtiServer", Struct(ServerBlock))
    extra_blocks: tuple[RawElement, ...] = extras()
