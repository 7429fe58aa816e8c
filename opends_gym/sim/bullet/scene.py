"""The world a `physics="bullet"` car drives in: ground, terrain and scene models as Bullet bodies.

Why: with the bullet backend obstacles are solid bodies (Bullet resolves the contacts), the
ground is what the wheels' suspension rays hit, and a model with mass can be pushed. This
module turns a task's scene (and the run-time `SceneObjects`) into bodies of one private
pybullet client; `bullet.vehicle.BulletVehicle` owns the client and the car.

- Ground: an infinite plane at the start pose's height (or the backend's `ground_height`),
  or an image height-map for a `terrain` geometry whose image is found (jME's
  ImageBasedHeightMap: height = grey level 0..255 times `heightScale`, grid centred on the
  model, one cell per metre times the model's scale; image row 0 is -Z, column 0 is -X:
  our reading), over a plane at its lowest level. Without the image the ground stays flat,
  as the loader already warned.
- Scene models: geometries (box, sphere, cylinder; jME sizes, cylinders along local Z)
  become shapes; `.obj` keys (a triangle mesh when static, its convex hull when dynamic)
  and `.urdf` keys are loaded when the file lies beside the task or at the asset root
  (three folders up, as OpenDS's `assets/DrivingTasks/Projects/<task>`); any other asset
  becomes a box of the size `assets.py` assumes, with one warning per model key.
  Mass 0 is static, mass > 0 dynamic. Trigger volumes, whole-scene meshes and points are
  not physical; nor are models that are not collidable, unless a `manipulateObject`
  action may switch that on (their body then waits with collisions off).
- Collision groups keep static bodies from pairing with each other (thousands of scenery
  models cost nothing per step) and keep the car's own wheel rays off its chassis.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

from ...task.missing_assets import find_asset
from ...task.model_scene import Box, Cylinder, Model, Point, Sphere, Terrain
from ...task.model_task import DrivingTask
from ...task.values import Quat
from ..scene_objects import SceneObject, SceneObjects

log = logging.getLogger(__name__)

# Collision filter groups. Rays are tested with pybullet's fixed ray group (bit 1), so any
# body a wheel ray may hit has bit 1 in its mask; no body is in group 1 itself.
G_RAY, G_STATIC, G_DYNAMIC, G_CAR = 1, 2, 4, 8
MASK_STATIC = G_RAY | G_DYNAMIC | G_CAR
MASK_DYNAMIC = G_RAY | G_STATIC | G_DYNAMIC | G_CAR
MASK_CAR = G_STATIC | G_DYNAMIC
RAY_MASK = G_STATIC | G_DYNAMIC


@dataclass(frozen=True)
class Placement:
    """What a body was last built or moved to, from its `SceneObject` (compared each step)."""

    position: tuple[float, float, float]
    yaw: float
    scale: tuple[float, float, float]
    collidable: bool


@dataclass
class SceneBody:
    """One scene model's Bullet body. `index` is its place in `SceneObjects.objects`."""

    index: int
    body: int
    dynamic: bool
    base_quat: Quat  # the model's rotation in the file (pitch/roll survive yaw changes)
    base_yaw: float
    links: int  # extra links of a URDF body (their collision filters follow the base)


def quat_mul(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def yaw_quat(yaw: float) -> Quat:
    return (0.0, math.sin(0.5 * yaw), 0.0, math.cos(0.5 * yaw))


def made_collidable_ids(task: DrivingTask) -> set[str]:
    """Scene models whose `collidable` flag a `manipulateObject` action may switch."""
    return {
        str(a.param("id"))
        for a in task.interaction.all_actions()
        if a.name == "manipulateObject" and a.param("id") and a.param("collidable") is not None
    }


def is_physical(o: SceneObject, model: Model, task: DrivingTask, switchable: set[str]) -> bool:
    """Bodies for obstacles that are collidable, or may become so; triggers, ground meshes and points never."""
    if o.is_trigger or o.kind in ("ground", "trigger"):
        return False
    if model.ref and isinstance(task.scene.geometry(model.ref), Point):
        return False
    return o.collidable or o.id in switchable


class SceneBuilder:
    """Builds the ground and the scene bodies into a pybullet client, in a fixed order."""

    def __init__(self, cid: int, task: DrivingTask, objects: SceneObjects, ground_y: float) -> None:
        self.cid = cid
        self.task = task
        self.objects = objects
        self.ground_y = ground_y
        self.warned: set[str] = set()
        self.warnings: list[str] = []
        switchable = made_collidable_ids(task)
        self.physical = [k for k, o in enumerate(objects.objects) if is_physical(o, task.scene.models[o.index], task, switchable)]
        self._shapes: dict[tuple[Any, ...], int] = {}

    def build(self, placements: dict[int, Placement]) -> tuple[list[int], list[SceneBody]]:
        """Ground bodies, then one body per physical scene model in index order, at the given placements."""
        self._shapes = {}
        ground = self._build_ground()
        return ground, [self._build_one(k, placements[k]) for k in self.physical]

    # ------------------------------------------------------------------ ground
    def _build_ground(self) -> list[int]:
        """The height-map terrain (if its image exists) over a floor plane; else one plane."""
        bodies: list[int] = []
        lows: list[float] = []
        for m in self.task.scene.models:
            g = self.task.scene.geometry(m.ref) if m.ref else None
            if isinstance(g, Terrain):
                built = self._terrain(m, g)
                if built is not None:
                    bodies.append(built[0])
                    lows.append(built[1])
        floor_y = min(lows) if lows else self.ground_y  # off the terrain the car drives on its lowest level
        plane = pb.createCollisionShape(pb.GEOM_PLANE, planeNormal=[0, 1, 0], physicsClientId=self.cid)
        body = pb.createMultiBody(0, plane, basePosition=[0.0, floor_y, 0.0], physicsClientId=self.cid)
        bodies.append(body)
        for b in bodies:
            pb.setCollisionFilterGroupMask(b, -1, G_STATIC, MASK_STATIC, physicsClientId=self.cid)
            pb.changeDynamics(b, -1, lateralFriction=1.0, physicsClientId=self.cid)
        return bodies

    def _terrain(self, model: Model, geo: Terrain) -> tuple[int, float] | None:
        path = find_asset(self.task.folder, geo.height_map_key)
        if path is None:
            return None
        try:
            from PIL import Image

            with Image.open(path) as img:
                grey = np.asarray(img.convert("L"), dtype=np.float64) * geo.height_scale  # row 0 at -Z
        except (OSError, ValueError) as exc:
            self._warn(f"terrain:{geo.height_map_key}", f"terrain image '{geo.height_map_key}' unreadable ({exc}); the ground is flat")
            return None
        rows, cols = grey.shape
        if rows < 2 or cols < 2:
            return None
        sx, sy, sz = (abs(v) or 1.0 for v in model.scale)
        # Bullet's height field is Z-up with local Y along its rows; turning it -90 degrees
        # about X maps local Z to world Y and local Y to world -Z, so rows are flipped.
        data = grey[::-1].ravel().tolist()
        lo, hi = float(grey.min()), float(grey.max())
        shape = pb.createCollisionShape(
            pb.GEOM_HEIGHTFIELD,
            meshScale=[sx, sz, sy],
            heightfieldData=data,
            numHeightfieldRows=cols,
            numHeightfieldColumns=rows,
            physicsClientId=self.cid,
        )
        tx, ty, tz = model.translation_m or (0.0, 0.0, 0.0)
        turn = (-math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4))
        orn = quat_mul(yaw_quat(model.rotation.yaw_rad), turn)
        # Bullet centres the field's height range on the body origin
        body = pb.createMultiBody(0, shape, basePosition=[tx, ty + 0.5 * (lo + hi) * sy, tz], baseOrientation=orn, physicsClientId=self.cid)
        return body, ty + lo * sy

    # ------------------------------------------------------------------ scene models
    def placement_of(self, k: int) -> Placement:
        o = self.objects.objects[k]
        return Placement(o.position, o.yaw, o.scale, o.collidable)

    def _build_one(self, k: int, pl: Placement) -> SceneBody:
        o = self.objects.objects[k]
        model = self.task.scene.models[o.index]
        dynamic = o.mass_kg > 0.0
        base_quat = model.rotation.quaternion
        base_yaw = model.rotation.yaw_rad
        orn = quat_mul(yaw_quat(pl.yaw - base_yaw), base_quat)
        path = find_asset(self.task.folder, model.key) if model.key.lower().endswith((".obj", ".urdf")) else None
        links = 0
        if path is not None and path.suffix.lower() == ".urdf":
            body = pb.loadURDF(
                str(path),
                basePosition=pl.position,
                baseOrientation=orn,
                useFixedBase=not dynamic,
                globalScaling=max(abs(v) for v in pl.scale) or 1.0,
                physicsClientId=self.cid,
            )
            links = pb.getNumJoints(body, physicsClientId=self.cid)
            if dynamic:
                pb.changeDynamics(body, -1, mass=o.mass_kg, physicsClientId=self.cid)
        else:
            shape = self._shape(o, model, pl.scale, path, dynamic)
            body = pb.createMultiBody(
                o.mass_kg if dynamic else 0.0, shape, basePosition=pl.position, baseOrientation=orn, physicsClientId=self.cid
            )
        sb = SceneBody(k, body, dynamic, base_quat, base_yaw, links)
        if dynamic:
            pb.changeDynamics(body, -1, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=self.cid)
        self.set_collidable(sb, pl.collidable)
        return sb

    def set_collidable(self, sb: SceneBody, on: bool) -> None:
        group, mask = (G_DYNAMIC, MASK_DYNAMIC) if sb.dynamic else (G_STATIC, MASK_STATIC)
        if not on:
            group = mask = 0
        for link in range(-1, sb.links):
            pb.setCollisionFilterGroupMask(sb.body, link, group, mask, physicsClientId=self.cid)

    def _shape(self, o: SceneObject, model: Model, scale: tuple[float, float, float], path: Path | None, dynamic: bool) -> int:
        sx, sy, sz = (abs(v) for v in scale)
        geo = self.task.scene.geometry(model.ref) if model.ref else None
        if isinstance(geo, Box):
            key: tuple[Any, ...] = ("box", geo.width_m * sx, geo.height_m * sy, geo.depth_m * sz)
        elif isinstance(geo, Sphere):
            key = ("sphere", geo.radius_m * max(sx, sy, sz))
        elif isinstance(geo, Cylinder):
            key = ("cylinder", geo.radius_m * max(sx, sy), geo.height_m * sz)
        elif path is not None:
            key = ("mesh", str(path), sx, sy, sz, dynamic)
        else:
            hx, hy, hz = (max(1e-3, h * s) for h, s in zip(o.base_half, (sx, sy, sz)))
            self._warn(
                f"model:{model.key}",
                f"scene model '{o.id}': no .obj/.urdf file for '{model.key}'; a {2 * hx:.2f} x {2 * hy:.2f} x {2 * hz:.2f} m box stands in",
            )
            key = ("box", hx, hy, hz)
        shape = self._shapes.get(key)
        if shape is None:
            shape = self._create_shape(key)
            self._shapes[key] = shape
        return shape

    def _create_shape(self, key: tuple[Any, ...]) -> int:
        kind = key[0]
        cid = self.cid
        if kind == "box":
            return int(pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[max(1e-3, v) for v in key[1:4]], physicsClientId=cid))
        if kind == "sphere":
            return int(pb.createCollisionShape(pb.GEOM_SPHERE, radius=max(1e-3, key[1]), physicsClientId=cid))
        if kind == "cylinder":
            return int(pb.createCollisionShape(pb.GEOM_CYLINDER, radius=max(1e-3, key[1]), height=max(1e-3, key[2]), physicsClientId=cid))
        _, path, sx, sy, sz, dynamic = key
        flags = 0 if dynamic else pb.GEOM_FORCE_CONCAVE_TRIMESH
        return int(pb.createCollisionShape(pb.GEOM_MESH, fileName=path, meshScale=[sx, sy, sz], flags=flags, physicsClientId=cid))

    def _warn(self, once_key: str, message: str) -> None:
        """Once per model key and backend (rebuilds on reset do not repeat it)."""
        if once_key in self.warned:
            return
        self.warned.add(once_key)
        self.warnings.append(message)
        log.warning("physics=bullet: %s", message)
