"""What the views draw besides the road, collected per frame near the viewer.

Why: the top-down map and the 3D views must show the same things - visible scene models
(trigger volumes only in debug), traffic cars with brake lights and blinking turn
signals, traffic lights coloured by their state, and the ego car - so both read them from
here. Everything is an upright box (`BoxRows`) or a small lit lamp quad (`LampRows`) in
world coordinates, plain rows the renderers turn into numpy arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..sim.scene_objects import SceneObject
from ..task.model_scene import Point
from . import palette as pal
from .palette import RGB
from .styles import Part, base_y, car_parts, parts_for

BLINK_HZ = 1.5  # turn signals: on for the first half of each period (simulation time)
LIGHT_POLE_M = 3.2
LIGHT_HOUSING_M = 1.0

# flags of a box row
SOLID, WIRE = 0, 1


@dataclass
class BoxRows:
    """Upright boxes: (cx, cz, yaw, y0, y1, hx, hz, r, g, b, flags, group) plus labels by row.

    `group` is the first row of the object a box belongs to: the 3D view orders objects by
    distance and draws an object's parts in row order (a car's body before its cabin).
    """

    rows: list[tuple[float, ...]] = field(default_factory=list)
    labels: dict[int, str] = field(default_factory=dict)

    def add(
        self,
        cx: float,
        cz: float,
        yaw: float,
        y0: float,
        y1: float,
        hx: float,
        hz: float,
        color: RGB,
        label: str = "",
        flags: int = SOLID,
        group: int = -1,
    ) -> int:
        i = len(self.rows)
        self.rows.append((cx, cz, yaw, y0, y1, hx, hz, color[0], color[1], color[2], flags, i if group < 0 else group))
        if label:
            self.labels[i] = label
        return i

    def add_parts(self, x: float, y: float, z: float, yaw: float, parts: tuple[Part, ...], flags: int = SOLID) -> int:
        """Place parts of an object at its pose; returns the index of the first row."""
        c, s = math.cos(yaw), math.sin(yaw)
        first = len(self.rows)
        for p in parts:
            self.add(x + p.dx * c + p.dz * s, z - p.dx * s + p.dz * c, yaw, y + p.y0, y + p.y1, p.hx, p.hz, p.color, p.label, flags, first)
        return first

    def array(self) -> np.ndarray:
        return np.asarray(self.rows, dtype=float).reshape(-1, 12)


@dataclass
class LampRows:
    """Lamps: (x, y, z, nx, nz, half_w, half_h, r, g, b, box) - a lit quad facing (nx, nz) on a box."""

    rows: list[tuple[float, ...]] = field(default_factory=list)

    def add(self, x: float, y: float, z: float, nx: float, nz: float, hw: float, hh: float, color: RGB, box: int) -> None:
        self.rows.append((x, y, z, nx, nz, hw, hh, color[0], color[1], color[2], box))

    def array(self) -> np.ndarray:
        return np.asarray(self.rows, dtype=float).reshape(-1, 11)


@dataclass(frozen=True)
class LightPlacement:
    light_id: str
    x: float
    y: float
    z: float
    yaw: float
    object_id: str  # the scene model drawn as this light ("" when placed at a waypoint)


def light_state(world: Any, light_id: str, initial: str) -> str:
    """red | yellow | green | yellowred | all | off, from the lights manager when there is one."""
    lights = getattr(world, "lights", None)
    state: Any = initial
    if lights is not None:
        try:
            state = lights.state_of(light_id)
        except (KeyError, ValueError, AttributeError):
            state = initial
    state = getattr(state, "value", getattr(state, "name", state))
    return str(state).lower()


LAMPS_BY_STATE: dict[str, tuple[bool, bool, bool]] = {
    "red": (True, False, False),
    "yellow": (False, True, False),
    "green": (False, False, True),
    "yellowred": (True, True, False),
    "all": (True, True, True),
    "off": (False, False, False),
}


class WorldScene:
    """Per-world cache of model looks and light placements; `collect()` lists what is near."""

    def __init__(self, world: Any, show_triggers: bool = False) -> None:
        self.world = world
        self.show_triggers = show_triggers
        self.models = world.task.scene.models
        self._parts: dict[tuple[int, tuple[float, float, float]], tuple[Part, ...]] = {}
        self.lights = self._place_lights()
        self._light_objects = {p.object_id for p in self.lights if p.object_id}
        self.light_states: list[tuple[float, float, str]] = []  # (x, z, state) of the lights last collected
        self._extents: tuple[Any, np.ndarray, np.ndarray] | None = None
        self._initial = self._initial_states()

    # ------------------------------------------------------------------ lights
    def _place_lights(self) -> list[LightPlacement]:
        task = self.world.task
        objects = self.world.objects.by_id
        points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}
        waypoints: dict[str, tuple[float, float, float]] = {}
        road = task.scenario.road
        if road.way_points is not None:
            for wp in road.way_points.points:
                pos = wp.translation_m or points.get(wp.ref)
                if wp.traffic_light and pos is not None:
                    waypoints.setdefault(wp.traffic_light, pos)
        for vehicle in task.scenario.traffic:
            for wp in getattr(vehicle, "way_points", ()):
                pos = wp.translation_m or points.get(wp.ref)
                if wp.traffic_light and pos is not None:
                    waypoints.setdefault(wp.traffic_light, pos)
        out = []
        for inter in road.intersections:
            for tl in inter.traffic_lights:
                obj = next((objects[k][0] for k in (tl.ref, tl.id) if k and k in objects), None)
                if obj is not None:
                    out.append(LightPlacement(tl.id, obj.position[0], obj.position[1], obj.position[2], obj.yaw, obj.id))
                elif tl.id in waypoints:
                    x, y, z = waypoints[tl.id]
                    out.append(LightPlacement(tl.id, x, y, z, 0.0, ""))
        return out

    def _initial_states(self) -> dict[str, str]:
        return {tl.id: tl.initial_state for inter in self.world.task.scenario.road.intersections for tl in inter.traffic_lights}

    # ------------------------------------------------------------------ collect
    def parts(self, obj: SceneObject) -> tuple[Part, ...]:
        key = (obj.index, obj.half)
        parts = self._parts.get(key)
        if parts is None:
            model = self.models[obj.index] if 0 <= obj.index < len(self.models) else None
            parts = self._parts[key] = parts_for(obj, model)
        return parts

    def collect(
        self, x: float, z: float, radius: float, include_ego: bool = True, buried_below_y: float | None = None
    ) -> tuple[BoxRows, LampRows]:
        """Boxes and lamps within `radius` metres of (x, z) at the world's current time.

        Scene models whose top is below `buried_below_y` are left out (the 3D view's ground
        would hide them; the map still shows them).
        """
        boxes, lamps = BoxRows(), LampRows()
        w = self.world
        objs: list[SceneObject] = w.objects.objects
        if objs:
            pos, reach = self._object_extents(objs)
            near = np.flatnonzero(np.hypot(pos[:, 0] - x, pos[:, 2] - z) <= radius + reach)
            for i in near.tolist():
                o = objs[i]
                if o.id in self._light_objects:
                    continue
                if o.is_trigger:
                    if self.show_triggers:
                        boxes.add_parts(o.position[0], base_y(o), o.position[2], o.yaw, self.parts(o), WIRE)
                    continue
                if o.visible:
                    parts, y = self.parts(o), base_y(o)
                    if buried_below_y is not None and y + max(p.y1 for p in parts) < buried_below_y:
                        continue
                    boxes.add_parts(o.position[0], y, o.position[2], o.yaw, parts)
        self._collect_lights(boxes, lamps, x, z, radius)
        self._collect_traffic(boxes, lamps, x, z, radius)
        if include_ego:
            self._collect_ego(boxes, lamps)
        return boxes, lamps

    def _object_extents(self, objs: list[SceneObject]) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3) and ground reach (N,) of all objects, recomputed only when poses or scales change."""
        key = ([o.position for o in objs], [o.scale for o in objs])
        if self._extents is None or self._extents[0] != key:
            pos = np.asarray(key[0], dtype=float).reshape(-1, 3)
            reach = np.asarray([max(o.half[0], o.half[2]) for o in objs], dtype=float)
            self._extents = (key, pos, reach)
        return self._extents[1], self._extents[2]

    def _collect_lights(self, boxes: BoxRows, lamps: LampRows, x: float, z: float, radius: float) -> None:
        self.light_states = []
        if not self.lights:
            return
        initial = self._initial
        for p in self.lights:
            if math.hypot(p.x - x, p.z - z) > radius:
                continue
            state = light_state(self.world, p.light_id, initial.get(p.light_id, "off"))
            self.light_states.append((p.x, p.z, state))
            on = LAMPS_BY_STATE.get(state, (False, False, False))
            boxes.add(p.x, p.z, p.yaw, p.y, p.y + LIGHT_POLE_M, 0.07, 0.07, pal.METAL)
            top = p.y + LIGHT_POLE_M
            k = boxes.add(p.x, p.z, p.yaw, top, top + LIGHT_HOUSING_M, 0.2, 0.2, pal.LIGHT_HOUSING, group=len(boxes.rows) - 1)
            colors = (pal.LAMP_RED, pal.LAMP_YELLOW, pal.LAMP_GREEN)
            for side in range(4):  # lamps on every side: who approaches from where is not in the task files
                a = p.yaw + side * 0.5 * math.pi
                nx, nz = math.sin(a), math.cos(a)
                for j in range(3):
                    y = top + LIGHT_HOUSING_M * (0.8 - 0.3 * j)
                    lamps.add(p.x + 0.2 * nx, y, p.z + 0.2 * nz, nx, nz, 0.12, 0.12, colors[j] if on[j] else pal.LAMP_DARK, k)

    def _collect_traffic(self, boxes: BoxRows, lamps: LampRows, x: float, z: float, radius: float) -> None:
        tr = self.world.traffic
        if tr is None or not len(getattr(tr, "ids", ())):
            return
        pos = np.asarray(tr.positions, dtype=float)
        d = np.hypot(pos[:, 0] - x, pos[:, 2] - z)
        enabled = np.asarray(tr.enabled, dtype=bool)
        blink_on = math.floor(self.world.t_s * 2.0 * BLINK_HZ) % 2 == 0
        for i in np.flatnonzero((d <= radius + 10.0) & enabled):
            hx, hz = (float(v) for v in tr.half_extents[i])
            height = 1.45 if hz < 4.0 else 3.2
            color = pal.TRAFFIC_BODIES[int(i) % len(pal.TRAFFIC_BODIES)]
            self._car(
                boxes,
                lamps,
                float(pos[i, 0]),
                float(pos[i, 1]),
                float(pos[i, 2]),
                float(tr.yaw[i]),
                hx,
                hz,
                height,
                color,
                bool(tr.brake_light[i]),
                int(tr.turn_signal[i]),
                blink_on,
            )

    def _collect_ego(self, boxes: BoxRows, lamps: LampRows) -> None:
        w = self.world
        box = w.ego_obb()
        spec = w.ego.spec
        inputs = w.ego.inputs
        signal = {"left": 1, "right": 2, "both": 3}.get(str(inputs.turn_signal), 0)
        blink_on = math.floor(w.t_s * 2.0 * BLINK_HZ) % 2 == 0
        self._car(
            boxes,
            lamps,
            box.cx,
            w.ego.state.y,
            box.cz,
            box.yaw,
            box.hx,
            box.hz,
            spec.height_m,
            pal.EGO,
            inputs.brake > 0.02,
            signal,
            blink_on,
        )

    @staticmethod
    def _car(
        boxes: BoxRows,
        lamps: LampRows,
        x: float,
        y: float,
        z: float,
        yaw: float,
        hx: float,
        hz: float,
        height: float,
        color: RGB,
        brake: bool,
        signal: int,
        blink_on: bool,
    ) -> None:
        k = boxes.add_parts(x, y, z, yaw, car_parts(hx, hz, height, color))
        c, s = math.cos(yaw), math.sin(yaw)
        rx, rz = s, c  # local +Z (the rear) in world
        lamp_y = y + 0.45 * height
        for side in (-1.0, 1.0):
            lx = side * (hx - 0.3)
            wx, wz = x + lx * c + hz * s, z - lx * s + hz * c
            lamps.add(wx + 0.02 * rx, lamp_y, wz + 0.02 * rz, rx, rz, 0.2, 0.08, pal.BRAKE_ON if brake else pal.BRAKE_OFF, k)
        for side, bit in ((-1.0, 1), (1.0, 2)):
            lit = blink_on and bool(signal & bit)
            lx = side * (hx - 0.06)
            for end in (1.0, -1.0):  # rear and front corners
                ex, ez = x + lx * c + end * hz * s, z - lx * s + end * hz * c
                lamps.add(
                    ex + 0.02 * end * rx,
                    lamp_y,
                    ez + 0.02 * end * rz,
                    end * rx,
                    end * rz,
                    0.06,
                    0.06,
                    pal.SIGNAL_ON if lit else pal.SIGNAL_OFF,
                    k,
                )
