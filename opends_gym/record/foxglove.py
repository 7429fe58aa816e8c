"""Foxglove messages that show a recording as a drive: the road, frame transforms, the view.

Why: Foxglove's 3D panel draws what `foxglove.SceneUpdate` entities, `foxglove.FrameTransforms`
and `foxglove.CompressedImage` messages describe; the World's models alone are boxes in
empty space. Here:

* `road_scene`: the road as the ego's `RoadGuide` knows it -- OpenDS X-band lanes (straight
  along Z over the task's extent) or a route (OpenDRIVE, road segments, waypoints) with its
  lanes -- as one entity with the surface (a triangle list) and one with the lane lines
  (a line list: solid outer edges, the lines between lanes), published once per file on
  `/foxglove/road`. Where no road is known, the update is empty.
* `frame_transforms`: world -> `ego` and world -> `vehicle_<N>` (N: the car's index in
  `/traffic`'s vehicles) per recorded step on `/tf`.
* `compressed_image`: an RGB frame as PNG or JPEG (pygame's encoders) on
  `/foxglove/driver_view`.

All coordinates are in the recording's Z-up `world` frame (`messages.zup_position`).
"""

from __future__ import annotations

import base64
import io
import math
from typing import Any

import numpy as np

from ..sim.guide import RoadGuide
from ..sim.world import World
from .messages import scene_entity, stamp, zup_position, zup_yaw_quaternion
from .schemas import EGO_FRAME, FRAME_ID

ROAD_RGBA = (0.35, 0.35, 0.37, 1.0)
LINE_RGBA = (0.95, 0.95, 0.95, 1.0)
LINE_WIDTH_M = 0.15  # painted line width (the renderer's markings)
STEP_M = 5.0  # route polylines are resampled this finely
LINE_LIST = 2  # foxglove.LinePrimitive type
IMAGE_FORMATS = ("png", "jpeg")


def _identity_pose() -> dict[str, Any]:
    return {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


def _rgba(c: tuple[float, ...]) -> dict[str, float]:
    return dict(zip("rgba", c))


def road_lines(world: World, guide: RoadGuide) -> tuple[list[np.ndarray], tuple[np.ndarray, np.ndarray]] | None:
    """The known road as OpenDS (x, z) polylines, each (N, 2): every lane line (lane edges,
    outer ones included) and the road's two edges. None where no road is known."""
    if guide.kind == "lanes":
        zs = [float(o.position[2]) for o in world.objects.objects] + [guide.start_xz[1]]
        z0, z1 = min(zs) - 50.0, max(zs) + 50.0
        bands = world.road.lanes
        xs = sorted({round(v, 6) for b in bands for v in (b.x_min, b.x_max)})
        lines = [np.array([[x, z0], [x, z1]]) for x in xs]
        return lines, (lines[0], lines[-1])
    if guide.kind == "route" and guide.polyline is not None:
        pl = guide.polyline
        n = max(2, int(math.ceil(pl.length / STEP_M)) + 1)
        pts = [pl.point_at(float(s)) for s in np.linspace(0.0, pl.length, n)]
        centre = np.array([[p[0], p[1]] for p in pts])
        heading = np.array([p[2] for p in pts])
        left = np.stack([-np.cos(heading), np.sin(heading)], axis=1)  # the road's left at heading h (OpenDS x, z)
        half = guide.lane_width_m / 2.0
        offsets = sorted({round(c + d, 6) for c in guide.lane_laterals_m for d in (-half, half)})
        lines = [centre + o * left for o in offsets]
        right_m, left_m = min(guide.road_edges_m[1], offsets[0]), max(guide.road_edges_m[0], offsets[-1])
        return lines, (centre + right_m * left, centre + left_m * left)
    return None


def road_scene(world: World, guide: RoadGuide) -> dict[str, Any]:
    """The `foxglove.SceneUpdate` of the road: entity `road/surface` (triangles) and
    `road/lane_lines` (a line list, two points per segment)."""
    t = world.t_s
    update: dict[str, Any] = {"deletions": [{"timestamp": stamp(t), "type": 1, "id": ""}], "entities": []}
    geometry = road_lines(world, guide)
    if geometry is None:
        return update
    lines, (a, b) = geometry
    y = float(world.start_pose.position_m[1])
    surface = scene_entity(t, "road/surface", "road")
    tri: list[dict[str, float]] = []
    for k in range(len(a) - 1):  # two triangles per segment between the edges
        p0, p1, q0, q1 = (zup_position(float(p[0]), y, float(p[1])) for p in (a[k], a[k + 1], b[k], b[k + 1]))
        tri += [p0, q0, p1, p1, q0, q1]
    surface["triangles"] = [{"pose": _identity_pose(), "points": tri, "color": _rgba(ROAD_RGBA), "colors": [], "indices": []}]
    marks = scene_entity(t, "road/lane_lines", "road")
    pts: list[dict[str, float]] = []
    for line in lines:
        for k in range(len(line) - 1):
            pts += [
                zup_position(float(line[k, 0]), y + 0.01, float(line[k, 1])),
                zup_position(float(line[k + 1, 0]), y + 0.01, float(line[k + 1, 1])),
            ]
    marks["lines"] = [
        {
            "type": LINE_LIST,
            "pose": _identity_pose(),
            "thickness": LINE_WIDTH_M,
            "scale_invariant": False,
            "points": pts,
            "color": _rgba(LINE_RGBA),
            "colors": [],
            "indices": [],
        }
    ]
    update["entities"] = [surface, marks]
    return update


def _transform(t_s: float, child: str, x: float, y: float, z: float, yaw: float) -> dict[str, Any]:
    return {
        "timestamp": stamp(t_s),
        "parent_frame_id": FRAME_ID,
        "child_frame_id": child,
        "translation": zup_position(x, y, z),
        "rotation": zup_yaw_quaternion(yaw),
    }


def frame_transforms(world: World, traffic: dict[str, Any] | None) -> dict[str, Any]:
    """`foxglove.FrameTransforms`: world -> ego and world -> vehicle_<N> (the same positions as
    `/ego` and `/traffic`)."""
    s = world.ego.state
    out = [_transform(world.t_s, EGO_FRAME, s.x, s.y, s.z, s.yaw)]
    for i, v in enumerate(traffic["vehicles"] if traffic is not None else ()):
        out.append(_transform(world.t_s, f"vehicle_{i}", v["x_m"], v["y_m"], v["z_m"], v["yaw_rad"]))
    return {"transforms": out}


def encode_image(frame: np.ndarray, fmt: str = "png") -> bytes:
    """An (H, W, 3) uint8 RGB frame as PNG or JPEG bytes."""
    import pygame

    if fmt not in IMAGE_FORMATS:
        raise ValueError(f"image format must be png or jpeg, not {fmt!r}")
    rgb = np.ascontiguousarray(np.asarray(frame, dtype=np.uint8)[:, :, :3])
    surface = pygame.image.frombuffer(rgb.tobytes(), (rgb.shape[1], rgb.shape[0]), "RGB")
    buf = io.BytesIO()
    pygame.image.save(surface, buf, f"frame.{'jpg' if fmt == 'jpeg' else 'png'}")
    return buf.getvalue()


def compressed_image(t_s: float, frame: np.ndarray, fmt: str = "png") -> dict[str, Any]:
    """`foxglove.CompressedImage` of the driver's view (JSON: the bytes as base64)."""
    return {"timestamp": stamp(t_s), "frame_id": EGO_FRAME, "data": base64.b64encode(encode_image(frame, fmt)).decode(), "format": fmt}
