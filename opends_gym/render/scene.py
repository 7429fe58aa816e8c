"""What the views know about a World's things besides the road: model looks and traffic lights.

Why: the map and the 3D views (`stage.Stage`) must show the same things: each scene
model's parts (`styles.parts_for`, cached per model and scale), where each traffic light
stands (its scene model, else the waypoint that names it) and which lamps its current
phase lights.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..sim.scene_objects import SceneObject
from ..task.model_scene import Point
from .styles import Part, parts_for

BLINK_HZ = 1.5  # turn signals: on for the first half of each period (simulation time)
LIGHT_POLE_M = 3.2
LIGHT_HOUSING_M = 1.0


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
    """Per-world cache of model looks and light placements."""

    def __init__(self, world: Any, show_triggers: bool = False) -> None:
        self.world = world
        self.show_triggers = show_triggers
        self.models = world.task.scene.models
        self._parts: dict[tuple[int, tuple[float, float, float]], tuple[Part, ...]] = {}
        self.lights = self._place_lights()
        self._light_objects = {p.object_id for p in self.lights if p.object_id}
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
