"""Ground assets a task names but does not carry, and the one warning about them.

Why: a task folder copied out of OpenDS lacks OpenDS's asset tree. Without a terrain's
height-map image (jME's `ImageBasedHeightMap`) or the scene mesh the roads are modelled in
(`Scenes/.../*.j3o`), our ground is flat where OpenDS's may climb or bank: speeds, pitch
and the car's height then differ from OpenDS's. Loading such a task raises one
`MissingAssetWarning` per task file (Python `warnings`: it can be filtered or made an
error), naming file, line and element of the first missing ground asset.

Not warned: other 3D models (signs, cars: a box of the declared scale stands in, logged at
INFO by the loader), OpenDS's stock flat planes (`Scenes/grassPlane`, `Scenes/land_plain_*`:
flat either way), and the bundled tasks, whose environments are specified on flat ground.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

from .bundled import BUNDLED_DIR
from .model_scene import Scene, Terrain

ASSET_ROOT_HOPS = (0, 3)  # the task folder, then OpenDS's asset root (assets/DrivingTasks/Projects/<task>)
GROUND_NAME = re.compile(r"(?i)terrain|road|street|ground")  # a mesh file named for the driving surface ...
NOT_GROUND = re.compile(r"(?i)sign")  # ... but not a road sign (Models/RoadSigns/.../PriorityRoad.scene)
FLAT_PLANE = re.compile(r"(?i)plane|plain")  # OpenDS's stock flat ground (grassPlane, land_plain_50x5)


def is_ground_mesh(key: str) -> bool:
    """A whole-scene mesh (`Scenes/...`) or a model file named for the road or terrain, not a flat plane."""
    name = key.rsplit("/", 1)[-1]
    ground = key.lower().startswith("scenes/") or (GROUND_NAME.search(name) is not None and NOT_GROUND.search(key) is None)
    return ground and FLAT_PLANE.search(key) is None


class MissingAssetWarning(UserWarning):
    """A task's height map or ground mesh is missing: the ground is flat, unlike OpenDS's."""


@dataclass(frozen=True)
class MissingAsset:
    kind: str  # "height map" | "scene mesh"
    key: str
    element: str  # terrain | model
    line: int | None


def find_asset(folder: Path, key: str) -> Path | None:
    """The file an asset key names, beside the task or at OpenDS's asset root, or None."""
    if not key:
        return None
    for hops in ASSET_ROOT_HOPS:
        base = folder
        for _ in range(hops):
            base = base.parent
        try:
            if (base / key).is_file():
                return base / key
        except (OSError, ValueError):  # a name the OS refuses is no file
            continue
    return None


def asset_exists(folder: Path, key: str) -> bool:
    """An asset key resolves beside the task or at OpenDS's asset root (an empty key needs nothing)."""
    return not key or find_asset(folder, key) is not None


def missing_ground(scene: Scene, folder: Path) -> list[MissingAsset]:
    """Missing terrain height-map images, then missing ground meshes, each key once, in file order."""
    out: list[MissingAsset] = []
    seen: set[str] = set()
    for g in scene.geometries:
        key = g.height_map_key if isinstance(g, Terrain) else ""
        if key and key not in seen and not asset_exists(folder, key):
            seen.add(key)
            out.append(MissingAsset("height map", key, "terrain", g.line))
    for m in scene.models:
        key = m.key
        if key and key not in seen and is_ground_mesh(key) and not asset_exists(folder, key):
            seen.add(key)
            out.append(MissingAsset("scene mesh", key, "model", m.line))
    return out


def warn_missing_ground(scene_file: Path, folder: Path, missing: list[MissingAsset]) -> None:
    """One `MissingAssetWarning` for a task file (none when nothing is missing or the task is bundled)."""
    if not missing or folder.resolve().is_relative_to(BUNDLED_DIR.resolve()):
        return
    first = missing[0]
    where = f"{scene_file}:{first.line} <{first.element}>" if first.line else f"{scene_file} <{first.element}>"
    what = ", ".join(f"{a.kind} '{a.key}'" for a in missing[:3]) + (f" and {len(missing) - 3} more" if len(missing) > 3 else "")
    warnings.warn(f"{where}: ground unknown, {what} not found: the ground is flat there, unlike OpenDS", MissingAssetWarning, stacklevel=4)
