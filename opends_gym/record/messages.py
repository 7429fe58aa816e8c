"""Message builders: World state -> JSON-ready dicts, and recorded dicts -> inputs again.

Why: the recorder writes these and `replay --check` rebuilds them from a re-simulated
World with the very same functions, so "reproduced exactly" means the same JSON text:
floats are written with Python's shortest round-trip repr (bit exact), inf/NaN become
null (JSON has neither).
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from typing import Any

import numpy as np

from ..metrics.headway import time_headway, time_to_collision
from ..sim.controls import DriverControls
from ..sim.events import Event
from ..sim.guide import RoadGuide
from ..sim.perception import lead_vehicle
from ..sim.triggers.reactions import ReactionResult
from ..sim.world import World
from .schemas import FRAME_ID

NS_PER_S = 1_000_000_000


def sim_ns(t_s: float) -> int:
    """MCAP log time: simulation seconds as integer nanoseconds."""
    return int(round(t_s * NS_PER_S))


def jsonable(v: Any) -> Any:
    """Plain JSON values: inf/NaN -> None, tuples/sets -> lists, numpy/enum/dataclass -> plain."""
    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else None
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, enum.Enum):
        return jsonable(v.value)
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    if isinstance(v, (set, frozenset)):
        return sorted((jsonable(x) for x in v), key=repr)
    if isinstance(v, np.ndarray):
        return jsonable(v.tolist())
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return jsonable(dataclasses.asdict(v))
    return str(v)


def _default(v: Any) -> Any:
    return jsonable(v)  # only called for what json cannot write itself (numpy, sets, enums...)


def encode(msg: dict[str, Any]) -> bytes:
    """Compact JSON; the fast path serialises directly, the slow one first maps inf/NaN to null."""
    try:
        return json.dumps(msg, separators=(",", ":"), allow_nan=False, default=_default).encode()
    except ValueError:  # a non-finite float somewhere
        return json.dumps(jsonable(msg), separators=(",", ":"), allow_nan=False).encode()


def normalized(msg: dict[str, Any]) -> Any:
    """The value a message has after a JSON round trip (what the file holds)."""
    return json.loads(encode(msg))


# ------------------------------------------------------------------ rotations
def jme_quaternion(pitch: float, yaw: float, roll: float) -> tuple[float, float, float, float]:
    """jMonkeyEngine `Quaternion.fromAngles(pitch, yaw, roll)` (x, y, z, w), as OpenDS writes it."""
    sx, cx = math.sin(pitch * 0.5), math.cos(pitch * 0.5)
    sy, cy = math.sin(yaw * 0.5), math.cos(yaw * 0.5)
    sz, cz = math.sin(roll * 0.5), math.cos(roll * 0.5)
    cycz, sysz, cysz, sycz = cy * cz, sy * sz, cy * sz, sy * cz
    w = cycz * cx - sysz * sx
    x = cycz * sx + sysz * cx
    y = sycz * cx + cysz * sx
    z = cysz * cx - sycz * sx
    return (x, y, z, w)


def yaw_from_jme_quaternion(qx: float, qy: float, qz: float, qw: float) -> float:
    """Heading (rotation about Y) of a jME quaternion (its `toAngles()[1]`)."""
    sqw, sqx, sqy, sqz = qw * qw, qx * qx, qy * qy, qz * qz
    return math.atan2(2.0 * qy * qw - 2.0 * qx * qz, sqx - sqy - sqz + sqw)


def zup_position(x: float, y: float, z: float) -> dict[str, float]:
    """OpenDS (Y up, forward -Z) -> Foxglove's Z-up frame (x forward at yaw 0, y left)."""
    return {"x": -z, "y": -x, "z": y}


def zup_yaw_quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw * 0.5), "w": math.cos(yaw * 0.5)}


def stamp(t_s: float) -> dict[str, int]:
    ns = sim_ns(max(t_s, 0.0))
    return {"sec": ns // NS_PER_S, "nsec": ns % NS_PER_S}


# ------------------------------------------------------------------ ego and inputs
def ego_message(world: World, guide: RoadGuide) -> dict[str, Any]:
    """The ego state after the last step (see `schemas.EGO_FIELDS` for units)."""
    s = world.ego.state
    inp = world.ego.inputs
    pt = world.ego.powertrain.state
    p = guide.locate(s.x, s.z)
    lane = p.lane_index
    center = guide.lane_laterals_m[lane if lane >= 0 else guide.nearest_lane(p.lateral_m)]
    qx, qy, qz, qw = jme_quaternion(s.pitch, s.yaw, s.roll)
    lead = lead_vehicle(world) if world.traffic is not None else None
    if lead is not None:
        gap, headway, ttc = lead.gap_m, time_headway(lead.gap_m, lead.length_m, s.u), time_to_collision(lead.gap_m, s.u, lead.speed_mps)
    else:
        gap = headway = ttc = math.inf
    return {
        "t_s": world.t_s,
        "step": world.step_count,
        "x_m": s.x,
        "y_m": s.y,
        "z_m": s.z,
        "yaw_rad": s.yaw,
        "pitch_rad": s.pitch,
        "roll_rad": s.roll,
        "qx": qx,
        "qy": qy,
        "qz": qz,
        "qw": qw,
        "speed_mps": s.u,
        "speed_kmh": s.u * 3.6,
        "lateral_speed_mps": s.v,
        "yaw_rate_radps": s.r,
        "wheel_angle_rad": s.steer_rad,
        "steering": inp.steering,
        "accelerator": inp.accelerator,
        "brake": inp.brake,
        "clutch": inp.clutch,
        "hand_brake": bool(inp.hand_brake),
        "turn_signal": inp.turn_signal,
        "gear": int(pt.gear),
        "automatic": bool(pt.automatic),
        "rpm": pt.rpm,
        "engine_on": bool(pt.engine_on),
        "fuel_used_l": pt.fuel_used_l,
        "odometer_m": pt.odometer_m,
        "cruise_active": bool(world.ego.cruise_active),
        "lane": world.road.lane_id_at(s.x),
        "lane_index": int(lane),
        "s_m": p.s_m,
        "lateral_m": p.lateral_m,
        "lane_offset_m": p.lateral_m - center,
        "lead_gap_m": gap,
        "headway_s": headway,
        "ttc_s": ttc,
        "collisions": int(world.collisions),
        "paused": bool(world.paused),
        "recording": bool(getattr(world.triggers, "recording", False)),
    }


_CONTROL_FIELDS = tuple(f.name for f in dataclasses.fields(DriverControls))
_TUPLE_FIELDS = ("keys", "buttons", "remote_triggers")


def controls_message(world: World, c: DriverControls) -> dict[str, Any]:
    msg: dict[str, Any] = {"t_s": world.t_s, "step": world.step_count}
    for name in _CONTROL_FIELDS:
        msg[name] = getattr(c, name)
    if c.steering_axis:  # written only when false: recordings made before the field replay unchanged
        del msg["steering_axis"]
    return msg


def controls_from_message(msg: dict[str, Any]) -> DriverControls:
    """The DriverControls a `/controls` message recorded (raises on unknown fields)."""
    unknown = set(msg) - set(_CONTROL_FIELDS) - {"t_s", "step"}
    if unknown:
        raise ValueError(f"/controls message has unknown fields {sorted(unknown)}")
    kwargs = {k: msg[k] for k in _CONTROL_FIELDS if k in msg}
    for k in _TUPLE_FIELDS:
        if k in kwargs and kwargs[k] is not None:
            kwargs[k] = tuple(kwargs[k])
    return DriverControls(**kwargs)


def action_message(t_s: float, index: int, action: Any) -> dict[str, Any]:
    """A policy action with enough type information to rebuild it bit for bit."""
    if isinstance(action, np.ndarray):
        return {
            "t_s": t_s,
            "index": index,
            "kind": "ndarray",
            "dtype": action.dtype.str,
            "shape": list(action.shape),
            "data": action.ravel().tolist(),
        }
    if isinstance(action, (bool, np.bool_)):
        return {"t_s": t_s, "index": index, "kind": "bool", "dtype": None, "shape": None, "data": bool(action)}
    if isinstance(action, (int, np.integer)):
        return {"t_s": t_s, "index": index, "kind": "int", "dtype": None, "shape": None, "data": int(action)}
    if isinstance(action, (float, np.floating)):
        if not math.isfinite(float(action)):
            return {"t_s": t_s, "index": index, "kind": "float", "dtype": None, "shape": None, "data": repr(float(action))}
        return {"t_s": t_s, "index": index, "kind": "float", "dtype": None, "shape": None, "data": float(action)}
    if isinstance(action, (list, tuple)):
        return action_message(t_s, index, np.asarray(action))
    raise TypeError(f"cannot record an action of type {type(action).__name__}")


def action_from_message(msg: dict[str, Any]) -> Any:
    kind = msg["kind"]
    if kind == "ndarray":
        data = [math.nan if v is None else v for v in msg["data"]]
        return np.asarray(data, dtype=np.dtype(msg["dtype"])).reshape(msg["shape"])
    if kind == "int":
        return int(msg["data"])
    if kind == "bool":
        return bool(msg["data"])
    if kind == "float":
        return float(msg["data"])
    raise ValueError(f"unknown recorded action kind {kind!r}")


# ------------------------------------------------------------------ traffic, events, reactions
def traffic_message(world: World) -> dict[str, Any] | None:
    """Every traffic object (duck-typed on the traffic manager's arrays); None without traffic."""
    tr = world.traffic
    ids = getattr(tr, "ids", None) if tr is not None else None
    if ids is None or len(ids) == 0:
        return None
    pos = tr.positions
    n = len(ids)

    def col(name: str, default: Any) -> list[Any]:
        arr = getattr(tr, name, None)
        return [default] * n if arr is None else list(arr)

    yaw, speed, enabled = col("yaw", 0.0), col("speed", 0.0), col("enabled", True)
    brake, signal = col("brake_light", False), col("turn_signal", None)
    vehicles = [
        {
            "id": str(ids[j]),
            "x_m": float(pos[j][0]),
            "y_m": float(pos[j][1]),
            "z_m": float(pos[j][2]),
            "yaw_rad": float(yaw[j]),
            "speed_mps": float(speed[j]),
            "enabled": bool(enabled[j]),
            "brake_light": bool(brake[j]),
            "turn_signal": jsonable(signal[j]),
        }
        for j in range(n)
    ]
    return {"t_s": world.t_s, "vehicles": vehicles}


def event_message(ev: Event) -> dict[str, Any]:
    return {"t_s": ev.t_s, "kind": ev.kind, "source": ev.source, "params": dict(ev.params)}


def reaction_message(r: ReactionResult) -> dict[str, Any]:
    return dataclasses.asdict(r)


# ------------------------------------------------------------------ Foxglove
def foxglove_pose(world: World) -> dict[str, Any]:
    s = world.ego.state
    return {
        "timestamp": stamp(world.t_s),
        "frame_id": FRAME_ID,
        "pose": {"position": zup_position(s.x, s.y, s.z), "orientation": zup_yaw_quaternion(s.yaw)},
    }


def scene_entity(t_s: float, eid: str, kind: str, **primitives: list[dict[str, Any]]) -> dict[str, Any]:
    """A `foxglove.SceneEntity` in the world frame, tagged with its `kind`: every primitive
    list the schema has is present (empty unless given, e.g. `cubes=[...]`)."""
    entity: dict[str, Any] = {
        "timestamp": stamp(t_s),
        "frame_id": FRAME_ID,
        "id": eid,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [{"key": "kind", "value": kind}],
    }
    for name in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"):
        entity[name] = primitives.pop(name, [])
    if primitives:
        raise TypeError(f"no SceneEntity primitive list {sorted(primitives)}")
    return entity


def _entity(
    t_s: float, eid: str, x: float, y: float, z: float, yaw: float, size: tuple[float, float, float], rgba: tuple[float, ...], kind: str
) -> dict[str, Any]:
    cube = {
        "pose": {"position": zup_position(x, y, z), "orientation": zup_yaw_quaternion(yaw)},
        # OpenDS half extents are (x across, y up, z along) -> Z-up (along, across, up)
        "size": {"x": size[2], "y": size[0], "z": size[1]},
        "color": dict(zip("rgba", rgba)),
    }
    return scene_entity(t_s, eid, kind, cubes=[cube])


_KIND_RGBA = {
    "obstacle": (0.55, 0.55, 0.6, 0.9),
    "vehicle": (0.2, 0.4, 0.9, 0.9),
    "trigger": (1.0, 0.8, 0.0, 0.15),
    "ground": (0.3, 0.3, 0.3, 0.3),
}


def scene_signature(world: World) -> list[tuple[Any, ...]]:
    return world.objects.get_state()


def foxglove_scene(world: World) -> dict[str, Any]:
    """Visible scene models and trigger volumes as boxes; the update replaces all earlier ones.

    The ego car itself is on `/foxglove/ego_pose` (published every sample); this topic is
    written at the start and whenever an action changed a model.
    """
    entities = []
    for o in world.objects.objects:
        if not o.visible and not o.is_trigger:
            continue
        hx, hy, hz = o.half
        entities.append(
            _entity(
                world.t_s,
                o.id,
                o.position[0],
                o.position[1],
                o.position[2],
                o.yaw,
                (2 * hx, 2 * hy, 2 * hz),
                _KIND_RGBA.get(o.kind, (0.6, 0.6, 0.6, 0.8)),
                o.kind,
            )
        )
    return {"deletions": [{"timestamp": stamp(world.t_s), "type": 1, "id": ""}], "entities": entities}


def foxglove_traffic(world: World, traffic: dict[str, Any]) -> dict[str, Any]:
    ents = []
    for v in traffic["vehicles"]:
        if v["enabled"]:
            ents.append(
                _entity(
                    world.t_s, v["id"], v["x_m"], v["y_m"] + 0.75, v["z_m"], v["yaw_rad"], (1.8, 1.5, 4.4), _KIND_RGBA["vehicle"], "traffic"
                )
            )
    return {"deletions": [{"timestamp": stamp(world.t_s), "type": 1, "id": ""}], "entities": ents}
