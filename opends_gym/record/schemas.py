"""JSON schemas of the recording's topics, and the Foxglove schemas we publish.

Why: an MCAP file is only self-describing if every channel names a schema. Our own
topics get JSON schemas generated from one field table (name, type, unit) so the docs and
the data cannot drift apart; the Foxglove topics use Foxglove's published schema names
(`foxglove.PoseInFrame`, `foxglove.SceneUpdate`, `foxglove.FrameTransforms`,
`foxglove.CompressedImage`) with the JSON encoding (bytes as base64 strings, as Foxglove's
JSON schemas say), which is what its 3D and Image panels look for.
"""

from __future__ import annotations

import json
from typing import Any

FORMAT = "opends_gym.drive/1"  # bump when a topic's meaning changes

# topic names
EGO = "/ego"
CONTROLS = "/controls"
ACTIONS = "/actions"
TRAFFIC = "/traffic"
EVENTS = "/events"
REACTIONS = "/reactions"
FOXGLOVE_POSE = "/foxglove/ego_pose"
FOXGLOVE_SCENE = "/foxglove/scene"
FOXGLOVE_TRAFFIC = "/foxglove/traffic"
FOXGLOVE_ROAD = "/foxglove/road"
FOXGLOVE_TF = "/tf"
FOXGLOVE_VIEW = "/foxglove/driver_view"
EGO_FRAME = "ego"  # world -> ego on /tf; traffic cars are vehicle_<N>, N their index in /traffic's vehicles
FRAME_ID = "world"  # OpenDS world turned Z-up: x = -Z_opends (forward at yaw 0), y = -X_opends, z = Y_opends

NUM = "number"
INT = "integer"
BOOL = "boolean"
STR = "string"

# (field, JSON type, description with unit). null is allowed for every number (inf/NaN).
EGO_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("t_s", NUM, "simulation time (s)"),
    ("step", INT, "physics step count since reset"),
    ("x_m", NUM, "OpenDS world X (m)"),
    ("y_m", NUM, "OpenDS world Y, up (m)"),
    ("z_m", NUM, "OpenDS world Z (m); yaw 0 faces -Z"),
    ("yaw_rad", NUM, "heading, + turns left (rad)"),
    ("pitch_rad", NUM, "pitch (rad)"),
    ("roll_rad", NUM, "roll (rad)"),
    ("qx", NUM, "rotation quaternion x (jMonkeyEngine convention, as carData.txt)"),
    ("qy", NUM, "rotation quaternion y"),
    ("qz", NUM, "rotation quaternion z"),
    ("qw", NUM, "rotation quaternion w"),
    ("speed_mps", NUM, "forward speed (m/s)"),
    ("speed_kmh", NUM, "forward speed (km/h)"),
    ("lateral_speed_mps", NUM, "sideways speed, + left (m/s)"),
    ("yaw_rate_radps", NUM, "yaw rate, + left (rad/s)"),
    ("wheel_angle_rad", NUM, "front wheel angle (rad)"),
    ("steering", NUM, "steering input as applied, -1..1, + left"),
    ("accelerator", NUM, "accelerator as applied (after cruise control and minSpeed), 0..1"),
    ("brake", NUM, "brake pedal as applied, 0..1"),
    ("clutch", NUM, "clutch pedal, 0..1"),
    ("hand_brake", BOOL, "hand brake engaged"),
    ("turn_signal", STR, "off | left | right | both"),
    ("gear", INT, "-1 reverse, 0 neutral, 1.. forward"),
    ("automatic", BOOL, "automatic gearbox"),
    ("rpm", NUM, "engine speed (1/min)"),
    ("engine_on", BOOL, "engine running"),
    ("fuel_used_l", NUM, "fuel used since reset (l)"),
    ("odometer_m", NUM, "distance driven since reset (m)"),
    ("cruise_active", BOOL, "cruise control engaged"),
    ("lane", STR, "OpenDS lane id (road/lane X band, 0.75 m margin); null between lanes"),
    ("lane_index", INT, "index of the lane the car is in along the road guide; -1 off the lanes"),
    ("s_m", NUM, "distance along the road guide (m)"),
    ("lateral_m", NUM, "position across the road guide, + left (m)"),
    ("lane_offset_m", NUM, "offset from the centre of the current (or nearest) lane, + left (m)"),
    ("lead_gap_m", NUM, "bumper-to-bumper gap to the lead vehicle (m); null without one"),
    ("headway_s", NUM, "front-to-front time headway (s); null without a lead"),
    ("ttc_s", NUM, "time to collision (s); null unless closing in"),
    ("collisions", INT, "collisions so far"),
    ("paused", BOOL, "simulation paused"),
    ("recording", BOOL, "OpenDS recording flag (startRecording/stopRecording)"),
)

CONTROLS_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("t_s", NUM, "simulation time after the step these inputs drove (s)"),
    ("step", INT, "physics step count after the step"),
    ("steering", NUM, "-1..1, + left"),
    ("accelerator", NUM, "0..1"),
    ("brake", NUM, "0..1"),
    ("clutch", NUM, "0..1"),
    ("gear", INT, "requested gear or null"),
    ("shift_up", BOOL, ""),
    ("shift_down", BOOL, ""),
    ("hand_brake", BOOL, ""),
    ("engine_on", BOOL, "engine switch request or null"),
    ("toggle_automatic", BOOL, ""),
    ("cruise_control", BOOL, "engage (true) / disengage (false) / null"),
    ("cruise_speed_delta_mps", NUM, "cruise target change (m/s)"),
    ("turn_signal", STR, "off | left | right | both | null"),
    ("horn", BOOL, ""),
    ("keys", "array", "key names pressed this step (jME names)"),
    ("buttons", "array", "joystick buttons pressed this step"),
    ("remote_triggers", "array", "remote trigger ids sent this step"),
    ("reset_to", STR, "reset point id or null"),
)
# optional: written only when false (keyboard or another non-axis steering source)
CONTROLS_OPTIONAL = (("steering_axis", BOOL, "steering from an analogue axis (absent: true)"),)


def _nullable(kind: str) -> Any:
    return [kind, "null"] if kind != "array" else "array"


def object_schema(title: str, description: str, fields: tuple[tuple[str, str, str], ...]) -> dict[str, Any]:
    return {
        "title": title,
        "description": description,
        "type": "object",
        "properties": {name: {"type": _nullable(kind), "description": desc} for name, kind, desc in fields},
        "required": [name for name, _, _ in fields],
    }


EGO_SCHEMA = object_schema("opends_gym.EgoState", "The ego car after a physics step (OpenDS world frame, Y up)", EGO_FIELDS)
CONTROLS_SCHEMA = object_schema(
    "opends_gym.DriverControls", "Driver inputs applied in one physics step (after range checks)", CONTROLS_FIELDS
)
CONTROLS_SCHEMA["properties"].update(object_schema("", "", CONTROLS_OPTIONAL)["properties"])
ACTION_SCHEMA: dict[str, Any] = {
    "title": "opends_gym.PolicyAction",
    "description": "The action passed to env.step(), exactly (dtype and shape kept for bit-exact replay)",
    "type": "object",
    "properties": {
        "t_s": {"type": "number", "description": "simulation time when the action was taken (s)"},
        "index": {"type": "integer", "description": "policy step since reset"},
        "kind": {"type": "string", "description": "ndarray | int | float | list"},
        "dtype": {"type": ["string", "null"]},
        "shape": {"type": ["array", "null"]},
        "data": {"description": "the value (flattened for arrays)"},
        "engine_key": {"type": "boolean", "description": "the ignition key turned on (off) with this action (OpenDSEnv.turn_engine_key)"},
        "reset_position": {
            "type": "boolean",
            "description": "the car was reset to its last lane position with this action (OpenDSEnv.reset_position)",
        },
    },
    "required": ["t_s", "index", "kind", "data"],
}
TRAFFIC_SCHEMA: dict[str, Any] = {
    "title": "opends_gym.TrafficState",
    "description": "Every traffic object after a physics step (OpenDS world frame)",
    "type": "object",
    "properties": {
        "t_s": {"type": "number"},
        "vehicles": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "id": {"type": "string"},
                    "x_m": {"type": "number"},
                    "y_m": {"type": "number"},
                    "z_m": {"type": "number"},
                    "yaw_rad": {"type": "number"},
                    "speed_mps": {"type": "number"},
                    "enabled": {"type": "boolean"},
                    "brake_light": {"type": "boolean"},
                    "turn_signal": {"type": ["string", "number", "boolean", "null"]},
                },
            },
        },
    },
    "required": ["t_s", "vehicles"],
}
EVENT_SCHEMA: dict[str, Any] = {
    "title": "opends_gym.Event",
    "description": "One entry of the World's event log (trigger, action, message, reaction, collision, recording, ...)",
    "type": "object",
    "properties": {
        "t_s": {"type": "number", "description": "simulation time (s)"},
        "kind": {"type": "string"},
        "source": {"type": "string", "description": "trigger id, action name, timer id, object id..."},
        "params": {"type": "object"},
    },
    "required": ["t_s", "kind", "source", "params"],
}
REACTION_SCHEMA: dict[str, Any] = {
    "title": "opends_gym.ReactionResult",
    "description": "A scored reaction trial, as OpenDS's reactionData.xml holds it",
    "type": "object",
    "properties": {
        "timer_id": {"type": "string"},
        "kind": {"type": "string", "description": "key | laneChange | brake | steering"},
        "group": {"type": "string", "description": "reaction group (settings.xml reactionMeasurement)"},
        "result": {"type": "integer", "description": "1 correct, -1 failure, -2 missed"},
        "reaction_time_s": {"type": "number", "description": "misses are logged with 10 s"},
        "start_t_s": {"type": "number"},
        "t_s": {"type": "number"},
        "experiment_time_s": {"type": "number", "description": "since startReactionMeasurement"},
        "comment": {"type": "string"},
        "extra": {"type": "object", "description": "additional timestamps, s after the start"},
    },
    "required": ["timer_id", "group", "result", "reaction_time_s", "t_s"],
}

# ------------------------------------------------------------------ Foxglove (published names, JSON encoding)
_TIME = {
    "type": "object",
    "title": "time",
    "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
}
_DURATION = {"type": "object", "title": "duration", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_VEC3 = {
    "title": "foxglove.Vector3",
    "type": "object",
    "properties": {k: {"type": "number"} for k in "xyz"},
    "required": list("xyz"),
}
_QUAT = {
    "title": "foxglove.Quaternion",
    "type": "object",
    "properties": {k: {"type": "number"} for k in "xyzw"},
    "required": list("xyzw"),
}
_POSE = {
    "title": "foxglove.Pose",
    "type": "object",
    "properties": {"position": _VEC3, "orientation": _QUAT},
    "required": ["position", "orientation"],
}
_COLOR = {"title": "foxglove.Color", "type": "object", "properties": {k: {"type": "number"} for k in "rgba"}, "required": list("rgba")}
_CUBE = {
    "title": "foxglove.CubePrimitive",
    "type": "object",
    "properties": {"pose": _POSE, "size": _VEC3, "color": _COLOR},
    "required": ["pose", "size", "color"],
}
_ANY_LIST = {"type": "array", "items": {"type": "object"}}
_ENTITY = {
    "title": "foxglove.SceneEntity",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "id": {"type": "string"},
        "lifetime": _DURATION,
        "frame_locked": {"type": "boolean"},
        "metadata": {
            "type": "array",
            "items": {"type": "object", "properties": {"key": {"type": "string"}, "value": {"type": "string"}}},
        },
        "arrows": _ANY_LIST,
        "cubes": {"type": "array", "items": _CUBE},
        "spheres": _ANY_LIST,
        "cylinders": _ANY_LIST,
        "lines": _ANY_LIST,
        "triangles": _ANY_LIST,
        "texts": _ANY_LIST,
        "models": _ANY_LIST,
    },
    "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "cubes"],
}
POSE_IN_FRAME_SCHEMA: dict[str, Any] = {
    "title": "foxglove.PoseInFrame",
    "description": "A timestamped pose for an object or reference frame in 3D space",
    "type": "object",
    "properties": {"timestamp": _TIME, "frame_id": {"type": "string"}, "pose": _POSE},
    "required": ["timestamp", "frame_id", "pose"],
}
SCENE_UPDATE_SCHEMA: dict[str, Any] = {
    "title": "foxglove.SceneUpdate",
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {"timestamp": _TIME, "type": {"type": "integer"}, "id": {"type": "string"}},
            },
        },
        "entities": {"type": "array", "items": _ENTITY},
    },
    "required": ["deletions", "entities"],
}

_FRAME_TRANSFORM = {
    "title": "foxglove.FrameTransform",
    "description": "A transform between two reference frames in 3D space",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "parent_frame_id": {"type": "string"},
        "child_frame_id": {"type": "string"},
        "translation": _VEC3,
        "rotation": _QUAT,
    },
    "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"],
}
FRAME_TRANSFORMS_SCHEMA: dict[str, Any] = {
    "title": "foxglove.FrameTransforms",
    "description": "An array of FrameTransform messages",
    "type": "object",
    "properties": {"transforms": {"type": "array", "items": _FRAME_TRANSFORM}},
    "required": ["transforms"],
}
COMPRESSED_IMAGE_SCHEMA: dict[str, Any] = {
    "title": "foxglove.CompressedImage",
    "description": "A compressed image",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "data": {"type": "string", "contentEncoding": "base64", "description": "Compressed image data"},
        "format": {"type": "string", "description": "Image format: png or jpeg"},
    },
    "required": ["timestamp", "frame_id", "data", "format"],
}

# topic -> (schema name, schema)
TOPICS: dict[str, tuple[str, dict[str, Any]]] = {
    EGO: ("opends_gym.EgoState", EGO_SCHEMA),
    CONTROLS: ("opends_gym.DriverControls", CONTROLS_SCHEMA),
    ACTIONS: ("opends_gym.PolicyAction", ACTION_SCHEMA),
    TRAFFIC: ("opends_gym.TrafficState", TRAFFIC_SCHEMA),
    EVENTS: ("opends_gym.Event", EVENT_SCHEMA),
    REACTIONS: ("opends_gym.ReactionResult", REACTION_SCHEMA),
    FOXGLOVE_POSE: ("foxglove.PoseInFrame", POSE_IN_FRAME_SCHEMA),
    FOXGLOVE_SCENE: ("foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    FOXGLOVE_TRAFFIC: ("foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    FOXGLOVE_ROAD: ("foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    FOXGLOVE_TF: ("foxglove.FrameTransforms", FRAME_TRANSFORMS_SCHEMA),
    FOXGLOVE_VIEW: ("foxglove.CompressedImage", COMPRESSED_IMAGE_SCHEMA),
}

# the state topics `replay --check` compares message by message
CHECKED_TOPICS = (EGO, CONTROLS, TRAFFIC, EVENTS, REACTIONS)


def schema_bytes(topic: str) -> tuple[str, bytes]:
    name, schema = TOPICS[topic]
    return name, json.dumps(schema, sort_keys=True).encode()
