"""`World`: one simulated driving task, advanced in fixed physics steps of simulation time.

Why: every env, the replay and the human mode drive the same core. A World owns its ego
car, scene objects, road, traffic, lights, trigger core and event log; nothing is
process-global, so any number of Worlds coexist (one per env, one per vector slot).
`get_state()`/`set_state()` capture everything that changes, so a run can be resumed and
repeated bit for bit.

Step order (one physics tick of `dt_s`):
1. the trigger core handles inputs (keys, buttons, pedals, remote ids) and runs actions
   whose delay has elapsed;
2. unless the simulation is paused: the ego car, traffic lights and traffic advance;
3. contacts: trigger volumes touched, obstacles and traffic hit (collision events);
4. the trigger core fires `collideWith` triggers and updates reaction timers;
5. `observers` (the drive recorder, viewers) see the finished step and the applied inputs.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..task import DrivingTask, load_task
from ..task.model_task import Pose
from .controls import DriverControls
from .ego.car import EgoCar, make_backend
from .events import EventLog
from .geometry2d import Obb, obb_overlap
from .lights import TrafficLights
from .road import RoadModel
from .scene_objects import SceneObject, SceneObjects
from .traffic.manager import TrafficManager
from .triggers import TriggerCore, make_trigger_core
from .world_config import WorldConfig

_NOTHING: frozenset[str] = frozenset()
# traffic this far above or below the ego is not hit (init_drive parks its pedestrians at y = -50
# until a trigger brings them up; OpenDS's 3-D physics never lets the car touch them there)
TRAFFIC_REACH_Y_M = 5.0


class World:
    """A driving task in simulation. See the module docstring for the step order."""

    def __init__(self, task: DrivingTask | str | Path, config: WorldConfig | None = None, seed: int | None = None) -> None:
        self.task = task if isinstance(task, DrivingTask) else load_task(task)
        self.config = config or WorldConfig()
        if self.config.physics not in ("fast", "bullet"):
            raise ValueError(f"unknown physics backend '{self.config.physics}' (use 'fast' or 'bullet')")
        self.dt_s = float(self.config.dt_s)
        self.events = EventLog()
        self.rng = np.random.default_rng(seed)
        self.road = RoadModel(self.task)
        self.objects = SceneObjects(self.task, extra_trigger_ids=_light_trigger_ids(self.task), opendrive=self.road.opendrive)
        backend = make_backend(self.config.physics, self.task, objects=self.objects)
        self.ego = EgoCar(self.task, backend)
        spec = self.ego.spec
        # the ego box: the body's reference point is its centre of gravity, the box is centred on the car
        self._box = (0.5 * spec.wheelbase_m - spec.cog_to_front_m, 0.5 * spec.width_m, 0.5 * spec.length_m)
        self.start_pose: Pose = self.road.driver_start_pose() or self.task.start_pose
        self.reset_poses = self.task.reset_poses()
        self.step_count = 0
        self.t_s = 0.0
        self.touching: frozenset[str] = frozenset()
        self._hitting: frozenset[str] = frozenset()
        self._free: tuple[float, float, float, int] = (0.0, 0.0, 0.0, -1)  # (x, z, room squared, objects.version)
        self.collisions = 0
        self.lights = _make_lights(self)
        # typed loosely: the platoon and brake envs index its cars by id without None checks
        self.traffic: Any = _make_traffic(self)
        self.triggers = _make_triggers(self)
        self._idle = DriverControls()
        # called as fn(world, applied_controls) after every step; kept across resets
        self.observers: list[Callable[[World, DriverControls], None]] = []
        self.reset(seed)

    # ------------------------------------------------------------------ lifecycle
    def reset(self, seed: int | None = None, start: Pose | None = None) -> None:
        """Back to the task's start: car at its scene pose, time 0, all managers fresh."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.step_count = 0
        self.t_s = 0.0
        self.events.clear()
        self.touching = frozenset()
        self._hitting = frozenset()
        self.collisions = 0
        self.road.reset()
        self.objects.reset()
        self.ego.reset(start or self.start_pose)
        if self.lights is not None:
            self.lights.reset()
        if self.traffic is not None:
            self.traffic.reset()
        self.triggers.reset()

    def close(self) -> None:
        self.ego.body.close()

    # ------------------------------------------------------------------ stepping
    @property
    def paused(self) -> bool:
        return bool(self.triggers.paused)

    def step(self, controls: DriverControls | None = None) -> None:
        """Advance one physics step with the given driver inputs (NaN and ranges sanitised)."""
        self.step_clipped((controls or self._idle).clipped())

    def step_clipped(self, c: DriverControls) -> None:
        """`step` with inputs that are `DriverControls.clipped()` already (an env applying one
        action for several physics steps clips it once)."""
        self.step_count += 1
        self.t_s = self.step_count * self.dt_s
        if c.reset_to is not None:
            self.reset_car(c.reset_to)
        self.triggers.before_physics(c)
        physics_on = not self.triggers.paused
        s = self.ego.state
        prev_x, prev_z = s.x, s.z
        if self.traffic is not None:
            self.ego.lead = self.traffic.lead_for_ego()
        self.ego.step(self.dt_s, c, physics_on)
        if physics_on:
            if self.lights is not None:
                self.lights.step(self.dt_s)
            if self.traffic is not None:
                self.traffic.step(self.dt_s)
            self._contacts(prev_x, prev_z)
        self.triggers.after_physics(c)
        for observe in self.observers:
            observe(self, c)

    def run(self, seconds: float, controls: DriverControls | None = None) -> None:
        """Step for `seconds` of simulation time with constant inputs."""
        for _ in range(int(round(seconds / self.dt_s))):
            self.step(controls)

    # ------------------------------------------------------------------ contacts
    def ego_obb(self) -> Obb:
        s = self.ego.state
        shift, hx, hz = self._box
        return Obb(s.x - shift * math.sin(s.yaw), s.z - shift * math.cos(s.yaw), s.yaw, hx, hz)

    def _contacts(self, prev_x: float, prev_z: float) -> None:
        s = self.ego.state
        shift, hx, hz = self._box
        yaw = s.yaw
        cx, cz = s.x - shift * math.sin(yaw), s.z - shift * math.cos(yaw)  # (ego_obb's centre)
        objects = self.objects
        free = self._free
        traffic = self.traffic
        if free[3] == objects.version and (cx - free[0]) ** 2 + (cz - free[1]) ** 2 < free[2]:
            # still inside the room measured last time: no trigger volume or obstacle can touch
            self.touching = _NOTHING
            if traffic is None:
                self._hitting = _NOTHING
                return
            triggers: list[SceneObject] = []
            obstacles: list[SceneObject] = []
            box = Obb(cx, cz, yaw, hx, hz)
        else:
            box = Obb(cx, cz, yaw, hx, hz)
            triggers, obstacles, room = objects.overlapping_with_room(box, s.y - 0.5, s.y + self.ego.spec.height_m)
            self._free = (cx, cz, room * room, objects.version)
            self.touching = frozenset(o.id for o in triggers) if triggers else _NOTHING
        hits = {o.id for o in obstacles} if obstacles else set()
        if traffic is not None:
            met = traffic.colliding_with(box)
            if met:  # boxes meet in plan view; a car or pedestrian parked far below or above does not
                hits.update(i for i in met if abs(float(traffic.positions[traffic.ids.index(i), 1]) - s.y) < TRAFFIC_REACH_Y_M)
        if not hits:  # the usual step: nothing hit, nothing to count
            self._hitting = _NOTHING
            return
        for oid in sorted(hits - self._hitting):  # a collision is counted when contact begins
            self.events.emit(self.t_s, "collision", oid, speed_kmh=abs(s.u) * 3.6)
            self.collisions += 1
        self._hitting = frozenset(hits)
        if obstacles and self.config.collision_stops_car:
            self.ego.body.stop_at_contact(prev_x, prev_z)

    # ------------------------------------------------------------------ actions
    def reset_car(self, reset_id: str) -> bool:
        """Move the car to a reset point (by id) at rest; False if there is no such point."""
        pose = self.reset_poses.get(reset_id)
        if pose is None:
            self.events.emit(self.t_s, "warning", "resetCar", message=f"no reset point '{reset_id}'")
            return False
        self.ego.teleport(pose)
        self.events.emit(self.t_s, "reset", reset_id)
        return True

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """Everything that changes during a run (deep-copied; safe to keep)."""
        return {
            "step_count": self.step_count,
            "rng": copy.deepcopy(self.rng.bit_generator.state),
            "ego": self.ego.get_state(),
            "objects": self.objects.get_state(),
            "road": self.road.get_state(),
            "touching": self.touching,
            "hitting": self._hitting,
            "collisions": self.collisions,
            "events": self.events.get_state(),
            "lights": self.lights.get_state() if self.lights is not None else None,
            "traffic": self.traffic.get_state() if self.traffic is not None else None,
            "triggers": self.triggers.get_state(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a state from `get_state()` of a World built from the same task and config."""
        state = copy.deepcopy(state)
        self.step_count = state["step_count"]
        self.t_s = self.step_count * self.dt_s
        self.rng.bit_generator.state = state["rng"]
        self.ego.set_state(state["ego"])
        self.objects.set_state(state["objects"])
        self.road.set_state(state["road"])
        self.touching = state["touching"]
        self._hitting = state["hitting"]
        self.collisions = state["collisions"]
        self.events.set_state(state["events"])
        if self.lights is not None:
            self.lights.set_state(state["lights"])
        if self.traffic is not None:
            self.traffic.set_state(state["traffic"])
        self.triggers.set_state(state["triggers"])


def _light_trigger_ids(task: DrivingTask) -> set[str]:
    """Scene models that request green when the car touches them (trigger-mode lights)."""
    ids: set[str] = set()
    for inter in task.scenario.road.intersections:
        for tl in inter.traffic_lights:
            ids.update(i for i in (tl.trigger, tl.phase_trigger) if i)
    return ids


def _make_lights(world: World) -> TrafficLights | None:
    if not world.task.scenario.road.intersections:
        return None
    return TrafficLights(world)


def _make_traffic(world: World) -> TrafficManager | None:
    if not world.config.traffic or not world.task.scenario.traffic:
        return None
    return TrafficManager(world)


def _make_triggers(world: World) -> TriggerCore:
    return make_trigger_core(world)


def obb_hits(a: Obb, boxes: list[Obb]) -> list[int]:
    """Indices of `boxes` that overlap `a` (helper for managers without numpy arrays)."""
    return [i for i, b in enumerate(boxes) if obb_overlap(a, b)]
