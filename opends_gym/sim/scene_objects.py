"""Scene models at run time: poses that actions change, visibility, trigger volumes.

Why: `manipulateObject` moves, scales and hides models; `collideWith` conditions test the
car against trigger volumes; static obstacles stop the car. This module keeps each model's
current oriented box (in the ground plane, plus a height range) in a uniform grid so the
per-step queries touch only the few objects near the car.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..task.conditions import CollideWith
from ..task.model_task import DrivingTask
from .assets import AssetShape, shape_of
from .geometry2d import Obb, obb_overlap

log = logging.getLogger(__name__)

CELL_M = 50.0


@dataclass
class SceneObject:
    """One model's run-time state. `half` is (x, y, z) half extents after scaling."""

    index: int
    id: str
    position: tuple[float, float, float]
    yaw: float
    scale: tuple[float, float, float]
    base_half: tuple[float, float, float]
    kind: str  # obstacle | ground | vehicle | trigger
    visible: bool
    collidable: bool  # physical obstacle for the car
    is_trigger: bool  # named by a collideWith condition
    mass_kg: float
    shape_source: str

    @property
    def half(self) -> tuple[float, float, float]:
        return (self.base_half[0] * abs(self.scale[0]), self.base_half[1] * abs(self.scale[1]), self.base_half[2] * abs(self.scale[2]))

    def obb(self) -> Obb:
        hx, _, hz = self.half
        return Obb(self.position[0], self.position[2], self.yaw, hx, hz)

    def y_range(self) -> tuple[float, float]:
        hy = self.half[1]
        return (self.position[1] - hy, self.position[1] + hy)


class SceneObjects:
    """All scene models except the ego car, indexed by a grid for nearby queries."""

    def __init__(
        self, task: DrivingTask, folder: Path | None = None, extra_trigger_ids: set[str] | None = None, opendrive: Any = None
    ) -> None:
        """`opendrive` (an `OpenDriveMap`) places models given by `openDrivePosition`."""
        self.task = task
        trigger_ids = {c.model_id for t in task.interaction.triggers for c in t.condition.items if isinstance(c, CollideWith)}
        trigger_ids |= extra_trigger_ids or set()
        car_ref = task.scenario.driver.car.ref
        self._initial: list[SceneObject] = []
        car_skipped = False
        for i, m in enumerate(task.scene.models):
            if m.id == car_ref and not car_skipped:
                car_skipped = True
                continue
            shape: AssetShape = shape_of(m, task.scene, folder or task.folder)
            is_trigger = m.id in trigger_ids
            if shape.kind == "ground" and not is_trigger:
                continue
            pos = m.translation_m or (0.0, 0.0, 0.0)
            yaw = m.rotation.yaw_rad
            odp = m.open_drive_position
            if odp is not None and m.translation_m is None:
                if opendrive is None:
                    msg = "model '%s' (scene.xml line %s) is placed on OpenDRIVE road '%s' but the task has no road file"
                    log.warning(msg, m.id, m.line, odp.road_id)
                else:
                    x, z, road_yaw = opendrive.position_to_world(odp.road_id, odp.s_m, odp.lateral_offset_m)
                    y = opendrive.elevation_m(odp.road_id, odp.s_m) + odp.vertical_offset_m
                    pos, yaw = (x, y, z), road_yaw + yaw
            self._initial.append(
                SceneObject(
                    index=i,
                    id=m.id,
                    position=pos,
                    yaw=yaw,
                    scale=m.scale,
                    base_half=shape.half_extents,
                    kind="trigger" if is_trigger else shape.kind,
                    visible=m.visible and not is_trigger,
                    collidable=(m.collision_shape != "none") and not is_trigger and shape.kind != "ground",
                    is_trigger=is_trigger,
                    mass_kg=m.mass_kg,
                    shape_source=shape.source,
                )
            )
        self.objects: list[SceneObject] = []
        self.by_id: dict[str, list[SceneObject]] = {}
        self._grid: dict[tuple[int, int], list[int]] = {}
        self.generation = 0  # counts resets, so physics backends can tell a World reset from a teleport
        self.version = 0  # counts grid rebuilds: a room measured by `overlapping_with_room` holds until it changes
        self.reset()

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Back to the scene's initial poses and flags. The SceneObject instances keep their
        identity across resets, so envs may hold references to the models they watch."""
        if not self.objects:
            self.objects = [replace(o) for o in self._initial]
            self.by_id = {}
            for o in self.objects:
                self.by_id.setdefault(o.id, []).append(o)
        else:
            for o, init in zip(self.objects, self._initial):
                o.position, o.yaw, o.scale, o.visible, o.collidable = init.position, init.yaw, init.scale, init.visible, init.collidable
        self.generation += 1
        self._rebuild_grid()

    def get_state(self) -> list[tuple[Any, ...]]:
        return [(o.position, o.yaw, o.scale, o.visible, o.collidable) for o in self.objects]

    def set_state(self, state: list[tuple[Any, ...]]) -> None:
        for o, (pos, yaw, scale, visible, collidable) in zip(self.objects, state):
            o.position, o.yaw, o.scale, o.visible, o.collidable = pos, yaw, scale, visible, collidable
        self._rebuild_grid()

    # ------------------------------------------------------------------ grid
    def _cells(self, o: SceneObject) -> list[tuple[int, int]]:
        hx, _, hz = o.half
        r = math.hypot(hx, hz)
        x0, x1 = int(math.floor((o.position[0] - r) / CELL_M)), int(math.floor((o.position[0] + r) / CELL_M))
        z0, z1 = int(math.floor((o.position[2] - r) / CELL_M)), int(math.floor((o.position[2] + r) / CELL_M))
        if (x1 - x0 + 1) * (z1 - z0 + 1) > 400:  # a huge object: keep it in a catch-all cell
            return [(1 << 30, 1 << 30)]
        return [(ix, iz) for ix in range(x0, x1 + 1) for iz in range(z0, z1 + 1)]

    def _rebuild_grid(self) -> None:
        self.version += 1
        self._grid = {}
        self._near_cache: dict[tuple[int, int, int, int], list[int]] = {}
        self._shapes: list[tuple[Any, ...] | None] = [None] * len(self.objects)
        for k, o in enumerate(self.objects):
            if o.is_trigger or o.collidable:
                for c in self._cells(o):
                    self._grid.setdefault(c, []).append(k)

    def update(self, obj: SceneObject) -> None:
        """Call after changing a trigger volume's or obstacle's pose, scale or flags (actions
        and the bullet backend do): the grid and the room the car was last given depend on it."""
        self._rebuild_grid()

    # ------------------------------------------------------------------ queries
    def _near_indices(self, x: float, z: float, radius: float) -> list[int]:
        """Indices of the grid objects near (x, z); cached per cell window until the grid changes
        (a car crosses a 50 m cell every couple of seconds, so most steps are one dict lookup)."""
        key = (math.floor((x - radius) / CELL_M), math.floor((x + radius) / CELL_M), math.floor((z - radius) / CELL_M),
               math.floor((z + radius) / CELL_M))  # fmt: skip
        found = self._near_cache.get(key)
        if found is not None:
            return found
        x0, x1, z0, z1 = key
        seen: set[int] = set()
        found = []
        grid = self._grid
        for ix in range(x0, x1 + 1):
            for iz in range(z0, z1 + 1):
                for k in grid.get((ix, iz), ()):
                    if k not in seen:
                        seen.add(k)
                        found.append(k)
        found.extend(k for k in grid.get((1 << 30, 1 << 30), ()) if k not in seen)
        if len(self._near_cache) >= 4096:  # bounded: a long drive visits many windows
            self._near_cache.clear()
        self._near_cache[key] = found
        return found

    def near(self, x: float, z: float, radius: float) -> list[SceneObject]:
        """Trigger volumes and obstacles whose grid cells touch a circle around (x, z)."""
        objects = self.objects
        return [objects[k] for k in self._near_indices(x, z, radius)]

    def _shape(self, k: int, o: SceneObject) -> tuple[float, float, Obb]:
        """(y low, y high, ground box) of object k, recomputed only when its pose or scale changed
        (checked by identity, so code that moves a model without `update()` is still seen)."""
        c = self._shapes[k]
        if c is not None and c[0] is o.position and c[1] is o.scale and c[2] == o.yaw:
            return c[3], c[4], c[5]
        lo, hi = o.y_range()
        box = o.obb()
        self._shapes[k] = (o.position, o.scale, o.yaw, lo, hi, box)
        return lo, hi, box

    def overlapping(self, car: Obb, y_lo: float, y_hi: float) -> tuple[list[SceneObject], list[SceneObject]]:
        """(trigger volumes, obstacles) the car box overlaps now."""
        triggers, obstacles, _ = self.overlapping_with_room(car, y_lo, y_hi)
        return triggers, obstacles

    def overlapping_with_room(self, car: Obb, y_lo: float, y_hi: float) -> tuple[list[SceneObject], list[SceneObject], float]:
        """`overlapping`, plus the room (m) the car's centre may move, turning as it likes,
        before any trigger volume or obstacle could touch it: the distance from the car's
        bounding circle to the nearest object's box (at any height) and to the edge of the
        grid cells searched (objects outside them cannot reach the circle). 0 while it
        touches or nearly touches one. Valid until `version` changes."""
        triggers: list[SceneObject] = []
        obstacles: list[SceneObject] = []
        objects = self.objects
        cx, cz, hx, hz = car.cx, car.cz, car.hx, car.hz
        radius = math.hypot(hx, hz)
        near = self._near_indices(cx, cz, radius)
        x0, x1 = math.floor((cx - radius) / CELL_M), math.floor((cx + radius) / CELL_M)
        z0, z1 = math.floor((cz - radius) / CELL_M), math.floor((cz + radius) / CELL_M)
        room = min(cx - radius - x0 * CELL_M, (x1 + 1) * CELL_M - cx - radius, cz - radius - z0 * CELL_M, (z1 + 1) * CELL_M - cz - radius)
        ra = hx * hx + hz * hz
        for k in near:
            o = objects[k]
            lo, hi, box = self._shape(k, o)
            dx, dz = box.cx - cx, box.cz - cz
            rb = box.hx * box.hx + box.hz * box.hz
            d2 = dx * dx + dz * dz
            c, sn = math.cos(box.yaw), math.sin(box.yaw)  # the car's centre in the box's frame (geometry2d's axes)
            u, v = abs(dx * c - dz * sn) - box.hx, abs(dx * sn + dz * c) - box.hz
            room = min(room, math.hypot(max(u, 0.0), max(v, 0.0)) - radius)  # centre-to-box distance, less the car's reach
            if hi < y_lo or lo > y_hi:
                continue
            if d2 > ra + rb + 2.0 * math.sqrt(ra * rb) or not obb_overlap(car, box):
                continue
            if o.is_trigger:
                triggers.append(o)
            elif o.collidable:
                obstacles.append(o)
        return triggers, obstacles, max(0.0, room - 1e-6)  # (a hair less: rounding never grants too much)
