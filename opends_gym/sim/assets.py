"""Sizes of scene models whose 3D assets we do not have.

Why: OpenDS task folders name assets (`Models/Cars/.../Car.j3o`) that live in OpenDS's
own asset tree, not beside the task. Collision and trigger volumes still need a size. In
order: a geometry `ref` (box/sphere/cylinder, jME semantics: box sizes are half extents);
an `.obj` file found beside the task (its vertex bounds); a rule for well-known OpenDS
asset folders (below, our assumptions, documented); else a 1 m cube, times the model's
declared scale. Whole-scene meshes (`Scenes/...`, roads, terrain) are the driving
surface, not obstacles.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..task.model_scene import Box, Cylinder, Model, Point, Scene, Sphere, Terrain


@dataclass(frozen=True)
class AssetShape:
    """Half extents (x, y, z) in metres at scale 1, and what the object is."""

    half_extents: tuple[float, float, float]
    kind: str  # obstacle | ground | vehicle | trigger
    source: str  # geometry | obj | catalogue | default


# (pattern on the asset key, half extents x/y/z, kind). Sizes of OpenDS's stock assets as
# we assume them; the trigger box spans a 5-lane road so no lane slips past it.
CATALOGUE: tuple[tuple[str, tuple[float, float, float], str], ...] = (
    (r"^Scenes/", (0.0, 0.0, 0.0), "ground"),
    (r"(?i)road|terrain|land_plain|grass|street|ground|delimiter", (0.0, 0.0, 0.0), "ground"),
    (r"(?i)^Models/Cars/", (0.9, 0.72, 2.2), "vehicle"),
    (r"(?i)^Models/trigger/", (10.0, 2.5, 0.5), "trigger"),
    (r"(?i)sign_bridges|bridge", (10.0, 3.5, 0.5), "obstacle"),
    (r"(?i)sign|panel", (0.8, 1.2, 0.1), "obstacle"),
    (r"(?i)pedestrian|person|man|woman", (0.3, 0.9, 0.3), "obstacle"),
)

DEFAULT = AssetShape((0.5, 0.5, 0.5), "obstacle", "default")


def _obj_bounds(path: Path) -> tuple[float, float, float] | None:
    """Half extents of a Wavefront OBJ's vertices (centred on its bounding box)."""
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    try:
        with path.open("r", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("v "):
                    parts = line.split()
                    for i in range(3):
                        c = float(parts[1 + i])
                        lo[i] = min(lo[i], c)
                        hi[i] = max(hi[i], c)
    except (OSError, ValueError, IndexError):
        return None
    if lo[0] == float("inf"):
        return None
    return tuple(0.5 * (h - low) for low, h in zip(lo, hi))  # type: ignore[return-value]


def shape_of(model: Model, scene: Scene, task_folder: Path) -> AssetShape:
    """Half extents (before the model's scale) and kind of one scene model."""
    if model.ref:
        g = scene.geometry(model.ref)
        if isinstance(g, Box):
            return AssetShape((g.width_m, g.height_m, g.depth_m), "obstacle", "geometry")
        if isinstance(g, Sphere):
            return AssetShape((g.radius_m, g.radius_m, g.radius_m), "obstacle", "geometry")
        if isinstance(g, Cylinder):
            # jME's cylinder runs along its local Z axis
            return AssetShape((g.radius_m, g.radius_m, 0.5 * g.height_m), "obstacle", "geometry")
        if isinstance(g, Terrain):
            return AssetShape((0.0, 0.0, 0.0), "ground", "geometry")
        if isinstance(g, Point):
            return AssetShape((0.05, 0.05, 0.05), "obstacle", "geometry")
    key = model.key
    if key.lower().endswith(".obj"):
        for base in (task_folder, task_folder.parent.parent.parent):
            bounds = _obj_bounds(base / key)
            if bounds is not None:
                return AssetShape(bounds, "obstacle", "obj")
    for pattern, half, kind in CATALOGUE:
        if re.search(pattern, key):
            return AssetShape(half, kind, "catalogue")
    return DEFAULT
