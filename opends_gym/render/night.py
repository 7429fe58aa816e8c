"""Night: how bright the scene's lights make the ground, and the ego's low beam in the dark.

Why: OpenDS has no night switch; a night drive is a scene whose `lights` (scene.xml:
`ambientLight`, `directionalLight`) are dim. jME lights a surface with ambient plus each
directional light's colour times max(0, N.L) (its Lighting material); for flat ground
(N up) that is `daylight()`, clamped to 1. Our meshes carry baked daylight colours, so a
frame is scaled by that level afterwards (as fog is blended), and the driver's low beam
brightens what it hits within `BEAM_RANGE_M` ahead inside `BEAM_HALF_ANGLE_RAD` of the
view's centre line (views from inside the car looking ahead only). A scene without
lights is daylight (OpenDS's defaults light it).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

DARK_BELOW = 0.999  # daylight levels from here up draw as day (no extra pass)
BEAM_RANGE_M = 60.0  # low beam reach (ECE R112: about 50-60 m of usable light)
BEAM_HALF_ANGLE_RAD = math.radians(20.0)


def daylight(world: Any) -> float:
    """Ground brightness under the task's scene lights, 0 (dark) .. 1 (day)."""
    lights = getattr(getattr(getattr(world, "task", None), "scene", None), "lights", ()) or ()
    if not lights:
        return 1.0
    level = 0.0
    for light in lights:
        rgba = getattr(light, "color_rgba", None)
        strength = float(np.mean(rgba[:3])) if rgba else 1.0  # jME's default light colour is white
        kind = type(light).__name__
        if kind == "AmbientLight":
            level += strength
        elif kind == "DirectionalLight":
            dx, dy, dz = light.direction
            norm = math.sqrt(dx * dx + dy * dy + dz * dz) or 1.0
            level += strength * max(0.0, -dy / norm)
    return min(1.0, max(0.0, level))


def darken(frame: np.ndarray, depth: np.ndarray, level: float, beam: bool, focal_px: float) -> None:
    """Scale a view (in place) to `level`; with `beam`, add the low beam by depth and column."""
    h, w = frame.shape[:2]
    gain = np.full((h, w), level)
    if beam:
        angle = np.abs(np.arctan((np.arange(w) + 0.5 - 0.5 * w) / focal_px))[None, :]
        lit = np.clip(1.0 - depth / BEAM_RANGE_M, 0.0, 1.0) * (angle < BEAM_HALF_ANGLE_RAD)
        gain = gain + (1.0 - level) * lit
    frame[:] = np.clip(frame * gain[..., None] + 0.5, 0, 255).astype(np.uint8)
