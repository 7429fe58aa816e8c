"""The trigger core: interaction.xml at run time.

Why: conditions fire triggers, triggers run their activities' actions (now or after a
delay), and actions change the world, the screen, and the reaction timers. One core per
World; every env, the recorder and the human mode read its results (`reactions`, `hud`,
the event log) instead of re-implementing any of it.

Semantics (OpenDS, with the differences stated):
* Conditions: collideWith (the car's box overlaps the trigger volume), pressKey /
  pressButton (a press this step), pressPedal (the pedal crosses its threshold upwards),
  remote (an id sent by `fire_remote` or `DriverControls.remote_triggers`),
  cameraWaypoint (the camera flight reaches the point), openDrivePos (the car is within
  0.5 m of `s` on that road and lane; needs a road model that knows OpenDRIVE positions).
* After firing, a trigger is locked for 2 s of simulation time plus the durations of the
  `pauseSimulation` actions it runs (a pause "until resumed" locks it until 2 s after the
  resume).
* When several triggers fire in one step they run by descending `priority`, ties in file
  order. OpenDS parses `priority` but ignores it (it runs them in detection order).
* `delay` counts simulation seconds (OpenDS: wall-clock timer threads), and delayed actions
  keep counting during a pause, as in OpenDS. `repeat` caps how often an action runs over
  the whole drive; 0 = unlimited.
* An action name OpenDS does not know is warned about once per name and skipped. An
  action that fails at run time (say, a traffic car the run does not have) is logged as a
  warning and skipped; it never stops the simulation.
"""

from __future__ import annotations

import copy
import heapq
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from ...task.actions_catalog import action_spec, typed_args
from ...task.conditions import (
    CameraWaypoint,
    CollideWith,
    OpenDrivePos,
    PressButton,
    PressKey,
    PressPedal,
    Remote,
    canonical_key,
)
from ...task.model_task import DrivingTask
from ..controls import DriverControls
from ..ego.car import EgoCar
from ..events import EventLog
from ..lights import TrafficLights
from ..road import RoadModel
from ..scene_objects import SceneObjects
from ..traffic.manager import TrafficManager
from ..world_config import WorldConfig
from .camera_flight import CameraFlight
from .hud import HudState
from .reaction_center import ReactionCenter
from .reactions import ReactionResult, axis_event


class TriggerWorld(Protocol):
    """What the trigger core and its actions read and change of their World (the World is
    one): the task, clock and event log, the ego car, road lanes, scene objects, traffic,
    lights, the world's settings, and the car reset (`resetCar`)."""

    task: DrivingTask
    config: WorldConfig
    events: EventLog
    t_s: float
    dt_s: float
    touching: frozenset[str]
    ego: EgoCar
    road: RoadModel
    objects: SceneObjects
    traffic: TrafficManager | None
    lights: TrafficLights | None

    def reset_car(self, reset_id: str) -> bool: ...


# an action handler: (core, typed arguments, trigger id)
Handler = Callable[["TriggerCore", dict[str, Any], str], None]

log = logging.getLogger(__name__)

LOCK_S = 2.0
OPENDRIVE_TOLERANCE_M = 0.5
CLOSE_INSTRUCTION_KEYS = frozenset({"KEY_RETURN", "KEY_SPACE"})


@dataclass(frozen=True)
class CompiledAction:
    counter: int  # index of the repeat counter (one per action element, shared by refs)
    name: str
    delay_s: float
    repeat: int
    args: dict[str, Any]
    line: int
    known: bool


@dataclass(frozen=True)
class CompiledTrigger:
    index: int
    id: str
    priority: int
    actions: tuple[CompiledAction, ...]
    pause_s: float  # lock extension from its pauseSimulation actions (inf: until resumed)
    line: int


@dataclass
class CarState:
    """The world as reaction timers see it in one step (see `reactions.CarView`)."""

    t_s: float
    x_m: float
    y_m: float
    z_m: float
    speed_mps: float
    steering: float
    accelerator: float
    brake: float
    keys: tuple[str, ...]
    axis_event: bool = False
    lanes: dict[str, tuple[float, float]] = field(default_factory=dict)
    lane_fn: Callable[[float, float], str | None] | None = None

    def lane_at(self, x: float, margin_m: float = 0.75) -> str | None:
        return self.lane_fn(x, margin_m) if self.lane_fn else None

    def lane_band(self, lane_id: str) -> tuple[float, float] | None:
        return self.lanes.get(lane_id)


class TriggerCore:
    """Runs a World's interaction.xml. See the module docstring for the semantics."""

    def __init__(self, world: TriggerWorld, handlers: Mapping[str, Handler]) -> None:
        """`handlers`: the actions this core carries out by action name (`make_trigger_core`
        passes the built-in ones of `actions`)."""
        self.world = world
        task = world.task
        self._custom: dict[str, Callable[[dict[str, Any]], None]] = {}
        self._handlers: dict[str, Handler] = dict(handlers)
        self.triggers: tuple[CompiledTrigger, ...] = self._compile(task)
        self._by_model: dict[str, list[int]] = {}
        self._by_key: dict[str, list[int]] = {}
        self._by_button: dict[int, list[int]] = {}
        self._by_remote: dict[str, list[int]] = {}
        self._by_waypoint: dict[str, list[int]] = {}
        self._pedal: list[tuple[int, PressPedal]] = []
        self._opendrive: list[tuple[int, OpenDrivePos]] = []
        for t, trig in zip(self.triggers, self._source_triggers):
            for c in trig.condition.items:
                if isinstance(c, CollideWith):
                    self._by_model.setdefault(c.model_id, []).append(t.index)
                elif isinstance(c, PressKey):
                    self._by_key.setdefault(c.key, []).append(t.index)
                elif isinstance(c, PressButton):
                    self._by_button.setdefault(c.button, []).append(t.index)
                elif isinstance(c, Remote):
                    self._by_remote.setdefault(c.trigger_id, []).append(t.index)
                elif isinstance(c, CameraWaypoint):
                    self._by_waypoint.setdefault(c.waypoint_id, []).append(t.index)
                elif isinstance(c, PressPedal):
                    self._pedal.append((t.index, c))
                elif isinstance(c, OpenDrivePos):
                    self._opendrive.append((t.index, c))
        self._lane_bands = {b.id: (b.x_min, b.x_max) for b in world.road.lanes}
        self.flight = CameraFlight(task)
        self.center = ReactionCenter(world.events, lambda: self.world.t_s)
        # only a steering reaction timer listens to the steering axis (SteeringReactionTimer)
        self._listens_to_axis = any(a.name == "setupSteeringReactionTimer" for t in self.triggers for a in t.actions)
        self.auto_close_instructions = bool(world.config.auto_close_instructions)
        self.reset()

    # ------------------------------------------------------------------ compile
    def _compile(self, task: Any) -> tuple[CompiledTrigger, ...]:
        inter = task.interaction
        counters: dict[tuple[int, int], int] = {}
        out: list[CompiledTrigger] = []
        self._source_triggers = []
        for trig in inter.triggers:
            actions: list[CompiledAction] = []
            pause = 0.0
            for activity in inter.resolved_activities(trig):
                for k, a in enumerate(activity.actions):
                    counter = counters.setdefault((id(activity), k), len(counters))
                    spec = action_spec(a.name)
                    args = typed_args(spec, a.params) if spec is not None else {}
                    actions.append(CompiledAction(counter, a.name, max(0.0, a.delay_s), a.repeat, args, a.line, spec is not None))
                    if a.name == "pauseSimulation":
                        d = float(args.get("duration_s", 1.0))
                        pause += d if d > 0 else math.inf
            if not actions:
                log.warning("interaction.xml line %s: trigger '%s' has no resolvable activity; discarded as in OpenDS", trig.line, trig.id)
                continue
            out.append(CompiledTrigger(len(out), trig.id, trig.priority, tuple(actions), pause, trig.line))
            self._source_triggers.append(trig)
        self._n_counters = len(counters)
        return tuple(out)

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        self.paused = False
        self.pause_until_s = 0.0
        self._pause_reason = ""
        self.shutdown_requested = False
        self.recording = False
        self.recording_track: int | None = None
        self.autopilot = bool(self.world.task.scenario.driver.open_drive and self.world.task.scenario.driver.open_drive.auto_pilot)
        self.hud = HudState(pictures={p.id: p.visible for p in self.world.task.scene.pictures})
        w = self.world.task.scenario.environment.weather
        self.weather = {"snowing_percent": w.snowing_percent, "raining_percent": w.raining_percent, "fog_percent": w.fog_percent}
        self.knowledge: dict[str, Any] = {}
        self.sounds_playing: set[str] = set()
        self.measurements: list[dict[str, Any]] = []
        self.active_reference_object: str | None = None
        self.requested_lane_change: str | None = None
        self._locks: dict[int, float] = {}
        self._counts = [0] * self._n_counters
        self._pending: list[tuple[float, int, int, int, str]] = []  # (due, seq, trigger, action pos, trigger id)
        self._seq = 0
        self._remote_queue: list[str] = []
        self._prev_pedals = {"accelerator": 0.0, "brake": 0.0, "clutch": 0.0, "combinedPedals": 0.0}
        self._od_inside: set[int] = set()
        self._warned: set[str] = set()
        self.center.clear()
        self._axis_prev = 0.0  # the steering axis value of the last step steered by an axis
        self._axis_event = False
        self.flight.reset()

    # ------------------------------------------------------------------ public API
    @property
    def reactions(self) -> list[ReactionResult]:
        """Scored reaction trials so far, in scoring order."""
        return self.center.results

    def add_action_handler(self, name: str, fn: Callable[[dict[str, Any]], None]) -> None:
        """Let an env give an action its task-specific meaning (fn receives the SI args)."""
        self._custom[name] = fn

    def fire_remote(self, trigger_id: str) -> None:
        """Queue a `remote:<id>` condition (settings-controller, CAN gateway, UI buttons)."""
        self._remote_queue.append(trigger_id)

    def fire(self, index: int) -> None:
        """Fire a trigger by its position in `triggers` now (tests, tools), honouring the lock."""
        self._fire_all([index], "manual")

    def close_timers(self) -> None:
        """End of the run: running reaction timers are logged as misses (as OpenDS on close)."""
        self.center.close(self.car_view())

    def close_instructions(self) -> None:
        if self.hud.instruction_screen is not None:
            self.world.events.emit(self.world.t_s, "instructions", self.hud.instruction_screen, op="close")
            self.hud.instruction_screen = None
            if math.isinf(self.pause_until_s) and self._pause_reason == "instructions":
                self.resume("instructions")

    def warn(self, source: str, message: str) -> None:
        """A run-time problem with the task: logged once per source and message, never raised."""
        key = f"{source}:{message}"
        if key not in self._warned:
            self._warned.add(key)
            log.warning("%s: %s", source, message)
        self.world.events.emit(self.world.t_s, "warning", source, message=message)

    # ------------------------------------------------------------------ pause
    def pause(self, duration_s: float, source: str, reason: str = "action") -> None:
        self.paused = True
        self.pause_until_s = self.world.t_s + duration_s if duration_s > 0 else math.inf
        self._pause_reason = reason
        self.world.events.emit(self.world.t_s, "pause", source, duration_s=duration_s)

    def resume(self, source: str) -> None:
        if not self.paused:
            return
        self.paused = False
        self.pause_until_s = 0.0
        t = self.world.t_s
        for k, until in self._locks.items():
            if math.isinf(until):
                self._locks[k] = t + LOCK_S
        self.world.events.emit(t, "resume", source)

    def shutdown(self, source: str) -> None:
        self.shutdown_requested = True
        self.close_timers()
        self.world.events.emit(self.world.t_s, "shutdown", source)

    def open_instructions(self, instruction_id: str) -> None:
        self.world.events.emit(self.world.t_s, "instructions", instruction_id, op="open")
        if self.auto_close_instructions:
            self.world.events.emit(self.world.t_s, "instructions", instruction_id, op="close", auto=True)
            return
        self.hud.instruction_screen = instruction_id
        self.pause(0.0, instruction_id, reason="instructions")

    # ------------------------------------------------------------------ stepping
    def before_physics(self, c: DriverControls) -> None:
        """Resume timed pauses, close instruction screens, run delayed actions now due."""
        t = self.world.t_s
        if self.paused and t >= self.pause_until_s - 1e-9:
            self.resume("pauseSimulation")
        if self.hud.instruction_screen is not None and (CLOSE_INSTRUCTION_KEYS & {canonical_key(k) for k in c.keys} or c.buttons):
            self.close_instructions()
        while self._pending and self._pending[0][0] <= t + 1e-9:
            _, _, ti, pos, tid = heapq.heappop(self._pending)
            self._run(self.triggers[ti].actions[pos], tid)

    def after_physics(self, c: DriverControls) -> None:
        """Evaluate conditions, fire triggers by priority, update measurements and timers."""
        w = self.world
        fired: list[int] = []
        keys = tuple(canonical_key(k) for k in c.keys) if c.keys else ()
        for k in keys:
            fired.extend(self._by_key.get(k, ()))
        for b in c.buttons:
            fired.extend(self._by_button.get(int(b), ()))
        if c.remote_triggers or self._remote_queue:
            remotes = list(c.remote_triggers) + self._remote_queue
            self._remote_queue = []
            for r in remotes:
                fired.extend(self._by_remote.get(r, ()))
        if self._pedal:  # (the previous pedals are read only by pedal conditions)
            pedals = {"accelerator": c.accelerator, "brake": c.brake, "clutch": c.clutch, "combinedPedals": max(c.accelerator, c.brake)}
            for ti, cond in self._pedal:
                if self._prev_pedals[cond.pedal] < cond.threshold <= pedals[cond.pedal]:
                    fired.append(ti)
            self._prev_pedals = pedals
        if not self.paused:
            if self.flight.state.active:
                for wp in self.flight.step(w.dt_s):
                    fired.extend(self._by_waypoint.get(wp, ()))
            for oid in w.touching:
                fired.extend(self._by_model.get(oid, ()))
            if self._opendrive:
                fired.extend(self._opendrive_fired())
        if fired:
            self._fire_all(fired, "condition")
        if self.measurements:
            self._update_measurements(c)
        if self._listens_to_axis:
            self._axis_event = c.steering_axis and axis_event(c.steering, self._axis_prev)
            if c.steering_axis:
                self._axis_prev = c.steering
        if not self.paused and self.center.timers:  # (the car view is built only for running timers)
            self.center.update(self.car_view(keys))

    def car_view(self, keys: tuple[str, ...] = ()) -> CarState:
        w = self.world
        s = w.ego.state
        inp = w.ego.inputs
        return CarState(
            t_s=w.t_s,
            x_m=s.x,
            y_m=s.y,
            z_m=s.z,
            speed_mps=s.u,
            steering=inp.steering,
            accelerator=inp.accelerator,
            brake=inp.brake,
            keys=keys,
            axis_event=self._axis_event,
            lanes=self._lane_bands,
            lane_fn=w.road.lane_id_at,
        )

    # ------------------------------------------------------------------ firing
    def _fire_all(self, indices: list[int], cause: str) -> None:
        order = sorted(set(indices), key=lambda i: (-self.triggers[i].priority, i))
        t = self.world.t_s
        for i in order:
            trig = self.triggers[i]
            if t < self._locks.get(i, -math.inf) - 1e-9:
                continue
            self._locks[i] = t + LOCK_S + trig.pause_s
            self.world.events.emit(t, "trigger", trig.id, priority=trig.priority, cause=cause)
            for pos, act in enumerate(trig.actions):
                if act.delay_s <= 0.0:
                    self._run(act, trig.id)
                else:
                    self._seq += 1
                    heapq.heappush(self._pending, (t + act.delay_s, self._seq, i, pos, trig.id))

    def _run(self, act: CompiledAction, trigger_id: str) -> None:
        if not act.known:
            if act.name not in self._warned:
                self._warned.add(act.name)
                log.warning("unknown action '%s' (interaction.xml line %s) is skipped, as in OpenDS", act.name, act.line)
                self.world.events.emit(self.world.t_s, "warning", act.name, message="unknown action skipped", line=act.line)
            return
        if act.repeat > 0 and self._counts[act.counter] >= act.repeat:
            return
        self._counts[act.counter] += 1
        self.world.events.emit(self.world.t_s, "action", act.name, trigger=trigger_id, **_plain(act.args))
        custom = self._custom.get(act.name)
        try:
            if custom is not None:
                custom(dict(act.args))
            else:
                self._handlers[act.name](self, act.args, trigger_id)
        except Exception as e:  # a running session must survive a bad action
            log.exception("action '%s' (line %s) failed", act.name, act.line)
            self.world.events.emit(self.world.t_s, "error", act.name, message=f"{type(e).__name__}: {e}", line=act.line)

    def _opendrive_fired(self) -> list[int]:
        if not self._opendrive:
            return []
        locate = getattr(self.world.road, "road_position", None)
        if locate is None:
            if "openDrivePos" not in self._warned:
                self.warn("openDrivePos", "this task's road has no OpenDRIVE positions; openDrivePos triggers cannot fire")
                self._warned.add("openDrivePos")
            return []
        out = []
        s = self.world.ego.state
        ego_pos = locate(s.x, s.z)
        for ti, cond in self._opendrive:
            pos = ego_pos
            if cond.traffic_car_id:
                pos = self.world.traffic.road_position_of(cond.traffic_car_id) if self.world.traffic is not None else None
            inside = (
                pos is not None
                and pos[0] == cond.road_id
                and (cond.lane == 0 or pos[1] == cond.lane)
                and abs(pos[2] - cond.s_m) < OPENDRIVE_TOLERANCE_M
            )
            if inside and ti not in self._od_inside:
                out.append(ti)
            (self._od_inside.add if inside else self._od_inside.discard)(ti)
        return out

    def _update_measurements(self, c: DriverControls) -> None:
        if not self.measurements:
            return
        w = self.world
        keep = []
        for m in self.measurements:
            if m["kind"] == "brake":
                done = w.ego.inputs.brake > 0.0
            else:
                done = abs(w.ego.speed_mps - m["start_speed_mps"]) >= m["speed_change_mps"]
            if done:
                w.events.emit(w.t_s, "measurement", m["name"], kind=m["kind"], elapsed_s=w.t_s - m["start_t_s"])
            else:
                keep.append(m)
        self.measurements = keep

    # ------------------------------------------------------------------ state
    _STATE = (
        "paused",
        "pause_until_s",
        "shutdown_requested",
        "recording",
        "recording_track",
        "autopilot",
        "hud",
        "weather",
        "knowledge",
        "sounds_playing",
        "measurements",
        "active_reference_object",
        "requested_lane_change",
        "_locks",
        "_counts",
        "_pending",
        "_seq",
        "_remote_queue",
        "_prev_pedals",
        "_od_inside",
        "_warned",
        "_pause_reason",
        "_axis_prev",
        "_axis_event",
    )

    def get_state(self) -> dict[str, Any]:
        state = {k: copy.deepcopy(getattr(self, k, None)) for k in self._STATE}
        c = self.center
        state["center"] = copy.deepcopy((c.known, c.timers, c.results, c.started, c.started_at_s))
        state["flight"] = copy.deepcopy(self.flight.state)
        return state

    def set_state(self, state: dict[str, Any]) -> None:
        state = copy.deepcopy(state)
        for k in self._STATE:
            setattr(self, k, state[k])
        c = self.center
        c.known, c.timers, c.results, c.started, c.started_at_s = state["center"]
        self.flight.state = state["flight"]


def _plain(args: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in args.items() if v is not None and v != ""}
