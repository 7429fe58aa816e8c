"""How a scene model looks without its 3D asset: a few coloured boxes per model.

Why: task folders name OpenDS assets (`Models/sign_bridges/...`, `Models/LaneChangeTest/
sign_lane1.scene`) that we do not ship. The collision size comes from `sim.assets`; this
module turns a model into recognisable parts (a gantry, an overhead panel, a roadside
sign on a post, a car with a cabin) so a driver - human or policy - can tell a brake
panel from a lane-change sign. Rules match the asset key (documented assumptions, like
`sim.assets.CATALOGUE`); a material colour in the scene file wins over our colours.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..sim.scene_objects import SceneObject
from ..task.model_scene import Model
from . import palette as pal
from .palette import RGB


@dataclass(frozen=True)
class Part:
    """An upright box in an object's local frame (x right, z back; metres above its base)."""

    dx: float
    dz: float
    y0: float
    y1: float
    hx: float
    hz: float
    color: RGB
    label: str = ""


OVERHEAD_BOARD_TOP_M = 5.9  # sign panels hang under the gantry beam (which starts at 6 m)
POST_SIGN_BOTTOM_M = 2.0


def _panel_look(key: str) -> tuple[RGB, str]:
    k = key.lower()
    if "brake" in k:
        return (190, 30, 30), "BRAKE"
    if "lanechange" in k and "sign_lane" not in k:
        return (30, 70, 190), "<  >"
    if "start" in k:
        return (30, 140, 60), "START"
    if "finish" in k:
        return (35, 35, 35), "FINISH"
    if "roadworks" in k:
        return (235, 165, 25), "!"
    m = re.search(r"sign_lane(\d+)", k)
    if m:
        return (20, 60, 170), m.group(1)
    return (30, 70, 150), ""


def car_parts(hx: float, hz: float, height: float, color: RGB) -> tuple[Part, ...]:
    """A car: lower body over the whole footprint and a glass cabin set back a little."""
    body_top = 0.62 * height
    return (
        Part(0.0, 0.0, 0.18 * height, body_top, hx, hz, color),
        Part(0.0, 0.12 * hz, body_top, height, 0.86 * hx, 0.55 * hz, pal.GLASS),
    )


def material_color(model: Model | None) -> RGB | None:
    if model is None or model.material is None or not model.material.color_rgba:
        return None
    c = model.material.color_rgba
    return (int(255 * min(1.0, max(0.0, c[0]))), int(255 * min(1.0, max(0.0, c[1]))), int(255 * min(1.0, max(0.0, c[2]))))


def parts_for(obj: SceneObject, model: Model | None) -> tuple[Part, ...]:
    """The boxes that stand in for one scene model at its current scale."""
    hx, hy, hz = obj.half
    key = (model.key if model is not None else "") or ""
    k = key.lower()
    mat = material_color(model)
    if obj.kind == "trigger":
        return (Part(0.0, 0.0, 0.0, 2 * hy, hx, hz, pal.TRIGGER_DEBUG),)
    if "bridge" in k:
        color = mat or pal.METAL
        post = 0.2
        beam = (Part(0.0, 0.0, max(0.0, 2 * hy - 1.0), 2 * hy, hx, max(hz, 0.3), color),)
        return (
            Part(-(hx - post), 0.0, 0.0, 2 * hy, post, post, color),
            Part(hx - post, 0.0, 0.0, 2 * hy, post, post, color),
            *beam,
        )
    if "sign_panels" in k:
        color, label = _panel_look(k)
        top = OVERHEAD_BOARD_TOP_M
        return (Part(0.0, 0.0, top - 2 * hy, top, hx, max(hz, 0.05), mat or color, label),)
    if "sign" in k and "models/cars" not in k:
        color, label = _panel_look(k)
        board = Part(0.0, 0.0, POST_SIGN_BOTTOM_M, POST_SIGN_BOTTOM_M + 2 * hy, hx, max(hz, 0.05), mat or color, label)
        return (Part(0.0, 0.0, 0.0, POST_SIGN_BOTTOM_M, 0.06, 0.06, pal.METAL), board)
    if obj.kind == "vehicle" or "models/cars/" in k:
        return car_parts(hx, hz, 2 * hy, mat or pal.TRAFFIC_BODIES[obj.index % len(pal.TRAFFIC_BODIES)])
    if "pedestrian" in k or "person" in k:
        return (Part(0.0, 0.0, 0.0, 2 * hy, hx, hz, mat or (200, 120, 80)),)
    if obj.shape_source == "geometry":
        return (Part(0.0, 0.0, 0.0, 2 * hy, hx, hz, mat or (150, 150, 150)),)
    return (Part(0.0, 0.0, 0.0, 2 * hy, hx, hz, mat or (160, 140, 110)),)


def base_y(obj: SceneObject) -> float:
    """Height of the model's base: jME geometries are centred on their translation, assets stand on it."""
    return obj.position[1] - obj.half[1] if obj.shape_source == "geometry" else obj.position[1]
