"""Built-in action handlers: what each OpenDS interaction action does in a World.

Why: OpenDS resolves an action id to an `InteractionMethods` method by reflection. Here
the same names map to small functions taking the core, the action's SI-typed arguments
(see `task.actions_catalog`) and the id of the trigger that ran it. Every handler writes
what it did to the event log; actions whose effect is outside the simulation (sounds,
movies, the parallel port, presentation tasks) exist only as events the human mode and
the recorder act on.
"""

from __future__ import annotations

import math
from typing import Any

from ...task.values import euler_deg_to_quat, yaw_from_quat
from .core import Handler, TriggerCore


def _emit(core: TriggerCore, kind: str, source: str, **params: Any) -> None:
    core.world.events.emit(core.world.t_s, kind, source, **params)


# ------------------------------------------------------------------ HUD and media
def send_message(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    d = float(a["duration_s"])
    core.hud.message = str(a["text"])
    core.hud.message_until_s = core.world.t_s + d if d > 0 else math.inf
    _emit(core, "message", trigger, text=core.hud.message, duration_s=d)


def manipulate_picture(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.hud.pictures[str(a["picture_id"])] = bool(a["visible"])
    _emit(core, "picture", str(a["picture_id"]), visible=bool(a["visible"]))


def open_instructions_screen(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.open_instructions(str(a["instruction_id"]))


def warning_frame(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    d = float(a["duration_s"])
    core.hud.warning_interval_s = float(a["interval_s"])
    core.hud.warning_until_s = core.world.t_s + d if d > 0 else core.world.t_s
    _emit(core, "warning_frame", trigger, interval_s=core.hud.warning_interval_s, duration_s=d)


def set_gauge(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    for key in ("auto_pilot_indicator", "speed_limit_indicator", "navigation_image_id"):
        if a.get(key) is not None:
            core.hud.gauge[key] = str(a[key])
    _emit(core, "gauge", trigger, **core.hud.gauge)


def sound(op: str) -> Handler:
    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        sid = str(a["sound_id"])
        if op == "play":
            core.sounds_playing.add(sid)
        else:
            core.sounds_playing.discard(sid)
        _emit(core, "sound", sid, op=op, trigger=trigger)

    return handler


def movie(op: str) -> Handler:
    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        _emit(core, "movie", str(a.get("movie_id") or ""), op=op, trigger=trigger)

    return handler


def parallel_port(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    _emit(core, "parallel_port", trigger, number=int(a["number"]), duration_s=float(a["duration_s"]))


def presentation_task(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.hud.presentation = {k: v for k, v in a.items() if v is not None}
    _emit(core, "presentation", str(a["type"]), **core.hud.presentation)


# ------------------------------------------------------------------ simulation control
def pause_simulation(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.pause(float(a["duration_s"]), trigger)


def resume_simulation(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.resume(trigger)


def shut_down(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.shutdown(trigger)


def start_recording(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.recording = True
    core.recording_track = a.get("track")
    _emit(core, "recording", trigger, op="start", track=core.recording_track)


def stop_recording(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.recording = False
    _emit(core, "recording", trigger, op="stop", track=core.recording_track)


# ------------------------------------------------------------------ the world
def manipulate_object(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    oid = str(a["object_id"])
    objs = core.world.objects.by_id.get(oid)
    if not objs:
        core.warn("manipulateObject", f"no scene model '{oid}' (or it is the driver's car)")
        return

    def vec(stem: str, unit: str) -> tuple[float | None, float | None, float | None]:
        return (a.get(f"{stem}_x_{unit}"), a.get(f"{stem}_y_{unit}"), a.get(f"{stem}_z_{unit}"))

    for o in objs:
        pos, scale = list(o.position), list(o.scale)
        for i, v in enumerate(vec("set_translation", "m")):
            if v is not None:
                pos[i] = v
        for i, v in enumerate(vec("add_translation", "m")):
            if v is not None:
                pos[i] += v
        for i, v in enumerate(vec("set_scale", "factor")):
            if v is not None:
                scale[i] = v
        for i, v in enumerate(vec("add_scale", "factor")):
            if v is not None:
                scale[i] += v
        set_yaw, add_yaw = vec("set_rotation", "rad")[1], vec("add_rotation", "rad")[1]
        if set_yaw is not None:
            o.yaw = yaw_from_quat(euler_deg_to_quat(0.0, math.degrees(set_yaw), 0.0))
        if add_yaw is not None:
            o.yaw += add_yaw
        o.position, o.scale = (pos[0], pos[1], pos[2]), (scale[0], scale[1], scale[2])
        if a.get("visible") is not None:
            o.visible = bool(a["visible"]) and not o.is_trigger
        if a.get("collidable") is not None:
            o.collidable = bool(a["collidable"]) and not o.is_trigger
        core.world.objects.update(o)
    _emit(core, "object", oid, **{k: v for k, v in a.items() if v is not None and k != "object_id"})


def reset_car(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.world.reset_car(str(a["reset_point_id"]))


def set_speed_limit(which: str) -> Handler:
    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        v = float(a["speed_limit_mps"])
        if which == "current":
            core.world.road.current_limit_mps = v
        else:
            core.world.road.upcoming_limit_mps = v
        _emit(core, "speed_limit", trigger, which=which, speed_limit_kmh=v * 3.6)

    return handler


def set_crosswind(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.world.ego.set_crosswind(str(a["direction"]), float(a["force"]), float(a["duration_s"]))
    _emit(core, "crosswind", trigger, direction=a["direction"], force=a["force"], duration_s=a["duration_s"])


def set_weather(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    for key in ("snowing_percent", "raining_percent", "fog_percent"):
        if a.get(key) is not None:
            core.weather[key] = float(a[key])
    _emit(core, "weather", trigger, **core.weather)


def set_auto_pilot(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.autopilot = bool(a["enabled"])
    _emit(core, "autopilot", trigger, enabled=core.autopilot)


def set_fuel_consumption(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.world.ego.powertrain.state.fuel_used_l = float(a["burned_fuel_l"])
    _emit(core, "fuel", trigger, fuel_used_l=float(a["burned_fuel_l"]))


def write_knowledge(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    raw = str(a["property_value"])
    kind = str(a["property_type"]).lower()
    value: Any = raw
    try:
        if kind in ("int", "integer", "long"):
            value = int(raw)
        elif kind in ("float", "double"):
            value = float(raw)
        elif kind in ("bool", "boolean"):
            value = raw.strip().lower() == "true"
    except ValueError:
        core.warn("writeToKnowledgeBase", f"'{raw}' is not a {kind}; stored as text")
    key = f"{a['path']}/{a['property_name']}".strip("/")
    core.knowledge[key] = value
    _emit(core, "knowledge", key, value=value)


def set_active_reference(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.active_reference_object = str(a["object_id"])
    _emit(core, "reference_object", core.active_reference_object)


# ------------------------------------------------------------------ traffic and lights
def move_traffic(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    traffic = core.world.traffic
    tid = str(a["traffic_object_id"])
    if traffic is None or traffic.index_of(tid) is None:
        core.warn("moveTraffic", f"no traffic object '{tid}' in this run")
        return
    if a.get("way_point_id"):
        traffic.move_to_waypoint(tid, str(a["way_point_id"]))
    if a.get("engine_on") is not None:
        traffic.set_engine_on(tid, bool(a["engine_on"]))
    if a.get("enabled") is not None:
        traffic.set_enabled(tid, bool(a["enabled"]))
    _emit(core, "traffic", tid, **{k: v for k, v in a.items() if v is not None and k != "traffic_object_id"})


def change_lane_od_car(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    tid = str(a.get("traffic_object_id") or "null")
    traffic = core.world.traffic
    if tid in ("", "null"):
        core.requested_lane_change = str(a["lane_pos"]).lower()
        _emit(core, "lane_change_request", "ego", side=core.requested_lane_change)
        return
    if traffic is None or traffic.index_of(tid) is None:
        core.warn("changeLaneODCar", f"no traffic object '{tid}' in this run")
        return
    traffic.request_lane_change(tid, -1 if str(a["lane_pos"]) == "Left" else 1)
    _emit(core, "lane_change_request", tid, side=str(a["lane_pos"]).lower())


def set_od_car_target_lane(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    tid = str(a["traffic_object_id"])
    traffic = core.world.traffic
    if traffic is None or traffic.index_of(tid) is None:
        core.warn("setODCarTargetLane", f"no traffic object '{tid}' in this run")
        return
    traffic.request_lane_change(tid, 0, target_lane=int(a["lane_id"]))
    _emit(core, "lane_change_request", tid, target_lane=int(a["lane_id"]))


def request_green(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    lid = str(a["traffic_light_id"])
    lights = core.world.lights
    if lights is None or not lights.has(lid):
        core.warn("requestGreenTrafficLight", f"no traffic light '{lid}'")
        return
    lights.request_green(lid)
    _emit(core, "traffic_light_request", lid)


# ------------------------------------------------------------------ reports
def report_text(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    _emit(core, "report", trigger, text=str(a["text"]), timestamp=bool(a["timestamp"]))


def report_speed(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    v = core.world.ego.speed_mps
    limit = float(a["speed_mps"])
    ok = v > limit if a["type"] == "greaterThan" else v < limit
    _emit(core, "report", trigger, what="speed", type=a["type"], threshold_kmh=limit * 3.6, speed_kmh=v * 3.6, condition_met=ok)


def report_traffic_light(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    lid = str(a["traffic_light_id"])
    lights = core.world.lights
    state = lights.state_of(lid) if lights is not None and lights.has(lid) else "unknown"
    expected = str(a["traffic_light_state"])
    _emit(
        core,
        "report",
        trigger,
        what="traffic_light",
        light=lid,
        state=state,
        expected=expected,
        condition_met=state.lower() == expected.lower(),
    )


# ------------------------------------------------------------------ measurements
def start_reaction_measurement(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
    core.center.start(core.car_view())


def setup_timer(kind: str) -> Handler:
    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        core.center.setup(kind, a, core.car_view())

    return handler


def measure_until(kind: str) -> Handler:
    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        core.measurements.append(
            {
                "name": str(a["trigger_name"]) or trigger,
                "kind": kind,
                "start_t_s": core.world.t_s,
                "start_speed_mps": core.world.ego.speed_mps,
                "speed_change_mps": float(a.get("speed_change_mps") or 0.0),
            }
        )

    return handler


def task_stimulus(name: str) -> Handler:
    """Actions whose meaning belongs to one task env (TVPT, ConTRe, motorway task): the env
    registers the real handler with `add_action_handler`; without one they are logged."""

    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        core.warn(name, "no task handler registered in this env; the stimulus is only logged")
        _emit(core, "stimulus", name, **{k: v for k, v in a.items() if v is not None})

    return handler


def logged(kind: str) -> Handler:
    """2023 actions that act on OpenDS's renderer or planner only: recorded, no effect."""

    def handler(core: TriggerCore, a: dict[str, Any], trigger: str) -> None:
        _emit(core, kind, trigger, **{k: v for k, v in a.items() if v is not None})

    return handler


BUILTIN_HANDLERS: dict[str, Handler] = {
    "sendMessage": send_message,
    "sendNumberToParallelPort": parallel_port,
    "manipulateObject": manipulate_object,
    "manipulatePicture": manipulate_picture,
    "pauseSimulation": pause_simulation,
    "resumeSimulation": resume_simulation,
    "shutDownSimulation": shut_down,
    "startRecording": start_recording,
    "stopRecording": stop_recording,
    "resetCar": reset_car,
    "moveTraffic": move_traffic,
    "setAutoPilot": set_auto_pilot,
    "startPresentationTask": presentation_task,
    "setCurrentSpeedLimit": set_speed_limit("current"),
    "setUpcomingSpeedLimit": set_speed_limit("upcoming"),
    "measureTimeUntilBrake": measure_until("brake"),
    "measureTimeUntilSpeedChange": measure_until("speed_change"),
    "playSound": sound("play"),
    "pauseSound": sound("pause"),
    "stopSound": sound("stop"),
    "playMovie": movie("play"),
    "playNextMovie": movie("play_next"),
    "stopMovie": movie("stop"),
    "requestGreenTrafficLight": request_green,
    "startReactionMeasurement": start_reaction_measurement,
    "setupKeyReactionTimer": setup_timer("key"),
    "setupReactionTimer": setup_timer("key"),
    "setupLaneChangeReactionTimer": setup_timer("laneChange"),
    "setupBrakeReactionTimer": setup_timer("brake"),
    "setupSteeringReactionTimer": setup_timer("steering"),
    "reportText": report_text,
    "reportSpeed": report_speed,
    "reportTrafficLight": report_traffic_light,
    "openInstructionsScreen": open_instructions_screen,
    "setCrosswind": set_crosswind,
    "setWeather": set_weather,
    "warningFrame": warning_frame,
    "setTVPTStimulus": task_stimulus("setTVPTStimulus"),
    "setMotorwayTaskStimulus": task_stimulus("setMotorwayTaskStimulus"),
    "setupContreTask": task_stimulus("setupContreTask"),
    "writeToKnowledgeBase": write_knowledge,
    "setActiveReferenceObject": set_active_reference,
    "setODCarTargetLane": set_od_car_target_lane,
    "changeLaneODCar": change_lane_od_car,
    "changeVehicleLayout": logged("vehicle_layout"),
    "setOpenDSGauge": set_gauge,
    "detachGeometryByTexturePath": logged("detach_geometry"),
    "addPlannerEvent": logged("planner_event"),
    "setFuelConsumption": set_fuel_consumption,
}
