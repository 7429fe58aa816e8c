"""Traffic lights: per-intersection programs in simulation time (OpenDS `TrafficLightCenter`).

Why: traffic cars stop for red lights on their next waypoint, `reportTrafficLight` and
`requestGreenTrafficLight` ask about and change lights, and the ego car touching a light's
`trigger` model asks for green. OpenDS runs one thread per intersection on wall-clock
sleeps; here each intersection is a small state machine advanced by `step(dt_s)`, so a run
is deterministic and `get_state()`/`set_state()` repeat it bit for bit.

Modes (per intersection, from `intersection@mode`; `set_mode`/`toggle_mode` switch them as
OpenDS's A key does, turning the lights off first):

* trigger: on entry every light is shifted to red (green -> yellow, 1 s, -> red). A request
  for green is queued; the lights in its `requiresRed` list (all lights of the intersection
  when it has none) are shifted to red (1 s per step), then the light shows yellow-red for
  1 s and green for at least 3 s before the next request is served. Green stays until a
  later request needs it red.
* program: the phases cycle with their durations; phase state strings hold one SUMO
  character per light at index `phasePosition - 1` (g/G green, y/Y yellow, r/R red,
  x/u yellow-red, o/O off, a all). Touching a `phaseTrigger` model reports the remaining
  red or green time.
* blinking: every light toggles between off and yellow each second.
* off: all lights off.  external: states only change through `set_external_state`.

Traffic stops for red, yellow and yellow-red (as OpenDS's `hasRedTrafficLight`).
Every change is written to `world.events` as kind "traffic_light".
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..task.model_road import TRAFFIC_LIGHT_MODES, Intersection
from ..task.model_task import DrivingTask
from .events import EventLog


class LightsWorld(Protocol):
    """What the lights read of their World (the World is one): the task's intersections, the
    clock and event log, and the trigger volumes the ego touches (trigger-mode lights)."""

    task: DrivingTask
    events: EventLog
    t_s: float
    touching: frozenset[str]


STATES = ("red", "yellow", "green", "yellowred", "off", "all")
RED, YELLOW, GREEN, YELLOWRED, OFF, ALL = range(6)
STOP_STATES = (RED, YELLOW, YELLOWRED)
SUMO_CHARS = {"g": GREEN, "G": GREEN, "y": YELLOW, "Y": YELLOW, "r": RED, "R": RED, "x": YELLOWRED, "u": YELLOWRED}
SUMO_CHARS.update({"o": OFF, "O": OFF, "a": ALL, "A": ALL})
SHIFT_S = 1.0  # OpenDS waits one second between shift steps and in yellow-red
GREEN_HOLD_S = 3.0  # minimum green before the next queued request is served
BLINK_S = 1.0


@dataclass
class _Program:
    """Run-time state of one intersection (everything here is copied by get_state)."""

    mode: str
    entered: bool = False
    phase: int = 0
    phase_end_s: float = 0.0
    queue: list[int] = field(default_factory=list)
    stage: str = "idle"  # idle | init2 | shift2 | settle | yellowred | hold
    stage_end_s: float = 0.0
    next_blink_s: float = 0.0


class TrafficLights:
    """All traffic lights of a World."""

    def __init__(self, world: LightsWorld) -> None:
        self.world = world
        self.intersections: tuple[Intersection, ...] = world.task.scenario.road.intersections
        self.ids: tuple[str, ...] = tuple(tl.id for inter in self.intersections for tl in inter.traffic_lights)
        self._index = {lid: i for i, lid in enumerate(self.ids)}
        self._initial = np.array([STATES.index(tl.initial_state) for i in self.intersections for tl in i.traffic_lights], dtype=np.int8)
        self._members: list[list[int]] = []  # light indices per intersection
        self._owner = np.zeros(len(self.ids), dtype=np.int32)
        self._position = np.zeros(len(self.ids), dtype=np.int32)  # phasePosition - 1 (-1 unknown)
        self._requires: list[list[int] | None] = []
        self._phases: list[list[tuple[str, float, str]]] = []
        self._by_trigger: dict[str, list[int]] = {}
        self._by_phase_trigger: dict[str, list[int]] = {}
        for k, inter in enumerate(self.intersections):
            members = [self._index[tl.id] for tl in inter.traffic_lights]
            self._members.append(members)
            self._phases.append([(p.id, max(0.0, p.duration_s), p.state) for p in inter.phases])
            for tl in inter.traffic_lights:
                i = self._index[tl.id]
                self._owner[i] = k
                self._position[i] = (tl.phase_position - 1) if tl.phase_position is not None else -1
                if tl.trigger:
                    self._by_trigger.setdefault(tl.trigger, []).append(i)
                if tl.phase_trigger:
                    self._by_phase_trigger.setdefault(tl.phase_trigger, []).append(i)
        for k, inter in enumerate(self.intersections):
            for tl in inter.traffic_lights:
                self._requires.append(self._rules(tl.requires_red, set(self._members[k])))
        self.states = self._initial.copy()
        self.stop_mask = np.zeros(len(self.ids), dtype=bool)
        self.t_s = 0.0
        self._programs: list[_Program] = []
        self._touching: frozenset[str] = frozenset()
        self.reset()

    def _rules(self, requires_red: str | None, members: set[int]) -> list[int] | None:
        if requires_red is None:
            return None
        out = []
        for name in requires_red.split(","):
            j = self._index.get(name.strip())
            if j is not None and j in members:
                out.append(j)
        return out

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        self.t_s = 0.0
        self._touching = frozenset()
        self.states = self._initial.copy()
        self._programs = [_Program(mode=inter.mode) for inter in self.intersections]
        for k, prog in enumerate(self._programs):
            if self._phases[k]:
                prog.phase_end_s = self._phases[k][0][1]
            if prog.mode == "program":  # OpenDS applies the first phase at construction
                for i in self._members[k]:
                    self.states[i] = self._phase_state(k, 0, i)
        self._update_mask()

    def get_state(self) -> dict[str, Any]:
        return {"t_s": self.t_s, "states": self.states.copy(), "programs": copy.deepcopy(self._programs), "touching": self._touching}

    def set_state(self, state: dict[str, Any]) -> None:
        self.t_s = state["t_s"]
        self.states = np.array(state["states"], dtype=np.int8)
        self._programs = copy.deepcopy(state["programs"])
        self._touching = state["touching"]
        self._update_mask()

    # ------------------------------------------------------------------ queries
    def has(self, light_id: str) -> bool:
        return light_id in self._index

    def index_of(self, light_id: str) -> int | None:
        return self._index.get(light_id)

    def state_of(self, light_id: str) -> str:
        """red | yellow | green | yellowred | off | all (KeyError for an unknown light)."""
        return STATES[int(self.states[self._index[light_id]])]

    def mode_of(self, intersection_id: str) -> str:
        return self._programs[self._intersection(intersection_id)].mode

    def remaining_s(self, light_id: str) -> tuple[str, float] | None:
        """Program mode: ('red', s until green) or ('green', s until not green); None if never/always."""
        i = self._index[light_id]
        k = int(self._owner[i])
        prog, phases = self._programs[k], self._phases[k]
        if prog.mode != "program" or not phases:
            return None
        green = self._phase_state(k, prog.phase, i) == GREEN
        left = max(0.0, prog.phase_end_s - self.t_s)
        j = prog.phase
        for _ in range(len(phases)):
            j = (j + 1) % len(phases)
            if (self._phase_state(k, j, i) == GREEN) != green:
                return ("green" if green else "red", left)
            left += phases[j][1]
        return None

    # ------------------------------------------------------------------ commands
    def request_green(self, light_id: str) -> bool:
        """Queue a request for green (trigger mode only, as in OpenDS). False if ignored."""
        i = self._index[light_id]
        prog = self._programs[int(self._owner[i])]
        if prog.mode != "trigger":
            self._emit_warning(light_id, f"green requested in {prog.mode} mode; only trigger mode serves requests")
            return False
        if i not in prog.queue:
            prog.queue.append(i)
        return True

    def set_mode(self, mode: str, intersection_id: str | None = None) -> None:
        """Switch one intersection (or all) to `mode`: lights go off, the mode starts next step."""
        if mode not in TRAFFIC_LIGHT_MODES:
            raise ValueError(f"unknown traffic light mode '{mode}' (use one of {', '.join(TRAFFIC_LIGHT_MODES)})")
        ks = range(len(self._programs)) if intersection_id is None else [self._intersection(intersection_id)]
        for k in ks:
            prog = self._programs[k]
            if prog.mode == mode:
                continue
            for i in self._members[k]:
                self._set(i, OFF)
            prog.mode, prog.entered, prog.stage, prog.queue = mode, False, "idle", []
            self.world.events.emit(self.world.t_s, "traffic_light_mode", self.intersections[k].id, mode=mode)
        self._update_mask()

    def toggle_mode(self) -> None:
        """Every intersection to its next mode: trigger -> program -> external -> blinking -> off -> trigger."""
        for k, prog in enumerate(self._programs):
            nxt = TRAFFIC_LIGHT_MODES[(TRAFFIC_LIGHT_MODES.index(prog.mode) + 1) % len(TRAFFIC_LIGHT_MODES)]
            self.set_mode(nxt, self.intersections[k].id)

    def set_external_state(self, light_id: str, state: str) -> bool:
        """External mode: set a light's state directly (ignored, with a warning, in other modes)."""
        i = self._index[light_id]
        if state not in STATES:
            raise ValueError(f"unknown traffic light state '{state}' (use one of {', '.join(STATES)})")
        if self._programs[int(self._owner[i])].mode != "external":
            self._emit_warning(light_id, "external state ignored: the intersection is not in external mode")
            return False
        self._set(i, STATES.index(state))
        self._update_mask()
        return True

    # ------------------------------------------------------------------ stepping
    def step(self, dt_s: float) -> None:
        self.t_s += dt_s
        self._contacts()
        for k, prog in enumerate(self._programs):
            if prog.mode == "trigger":
                self._run_trigger(k, prog)
            elif prog.mode == "program":
                self._run_program(k, prog)
            elif prog.mode == "blinking":
                if not prog.entered or self.t_s >= prog.next_blink_s - 1e-9:
                    for i in self._members[k]:
                        self._set(i, YELLOW if self.states[i] == OFF else OFF)
                    prog.next_blink_s = self.t_s + BLINK_S
            elif prog.mode == "off" and not prog.entered:
                for i in self._members[k]:
                    self._set(i, OFF)
            prog.entered = True
        self._update_mask()

    def _contacts(self) -> None:
        touching = self.world.touching
        for model_id in touching:
            for i in self._by_trigger.get(model_id, ()):
                prog = self._programs[int(self._owner[i])]
                if prog.mode != "trigger":
                    continue
                if i not in prog.queue:  # OpenDS re-requests every frame of contact
                    prog.queue.append(i)
                if model_id not in self._touching:
                    self.world.events.emit(self.world.t_s, "traffic_light_request", self.ids[i], state=STATES[self.states[i]])
            if model_id not in self._touching:
                for i in self._by_phase_trigger.get(model_id, ()):
                    if self._programs[int(self._owner[i])].mode != "program":
                        continue
                    rem = self.remaining_s(self.ids[i])
                    self.world.events.emit(
                        self.world.t_s,
                        "traffic_light_report",
                        self.ids[i],
                        state=STATES[self.states[i]],
                        remaining_kind=rem[0] if rem else None,
                        remaining_s=rem[1] if rem else None,
                    )
        self._touching = touching

    def _run_program(self, k: int, prog: _Program) -> None:
        phases = self._phases[k]
        if not phases:
            if not prog.entered:
                for i in self._members[k]:
                    self._set(i, OFF)
            return
        changed = not prog.entered
        total = sum(p[1] for p in phases)
        while total > 0.0 and self.t_s >= prog.phase_end_s - 1e-9:
            prog.phase = (prog.phase + 1) % len(phases)
            prog.phase_end_s += phases[prog.phase][1]
            changed = True
        if changed:
            for i in self._members[k]:
                self._set(i, self._phase_state(k, prog.phase, i))

    def _run_trigger(self, k: int, prog: _Program) -> None:
        t = self.t_s
        if not prog.entered:  # (set_mode already emptied the queue; a request made before the first step is kept)
            prog.stage = "idle"
            if not self._shift_red(k, None):
                prog.stage, prog.stage_end_s = "init2", t + SHIFT_S
        for _ in range(8):  # a finished stage may start the next one in the same step
            if prog.stage == "idle":
                if not prog.queue:
                    return
                light = prog.queue[0]
                if self.states[light] == GREEN:
                    prog.queue.pop(0)
                    continue
                all_red = self._shift_red(k, light)
                prog.stage, prog.stage_end_s = ("settle" if all_red else "shift2"), t + SHIFT_S
                return
            if t < prog.stage_end_s - 1e-9:
                return
            light = prog.queue[0] if prog.queue else -1
            if prog.stage == "init2":
                self._shift_red(k, None)
                prog.stage = "idle"
            elif prog.stage == "shift2":
                self._shift_red(k, light)
                prog.stage, prog.stage_end_s = "settle", prog.stage_end_s + SHIFT_S
            elif prog.stage == "settle":
                if light >= 0 and self._all_red(k, light):
                    self._set(light, YELLOWRED)
                    prog.stage, prog.stage_end_s = "yellowred", prog.stage_end_s + SHIFT_S
                else:
                    self._pop(prog)
            elif prog.stage == "yellowred":
                self._set(light, GREEN)
                prog.stage, prog.stage_end_s = "hold", prog.stage_end_s + GREEN_HOLD_S
            elif prog.stage == "hold":
                self._pop(prog)

    @staticmethod
    def _pop(prog: _Program) -> None:
        if prog.queue:
            prog.queue.pop(0)
        prog.stage = "idle"

    def _targets(self, k: int, light: int | None) -> list[int]:
        if light is None:
            return self._members[k]
        rules = self._requires[light]
        return self._members[k] if rules is None else rules

    def _shift_red(self, k: int, light: int | None) -> bool:
        """One step toward red for the lights `light` needs red; True if they all are red now."""
        for i in self._targets(k, light):
            s = self.states[i]
            if s == YELLOW:
                self._set(i, RED)
            elif s != RED:
                self._set(i, YELLOW)
        return self._all_red(k, light)

    def _all_red(self, k: int, light: int | None) -> bool:
        return all(self.states[i] == RED for i in self._targets(k, light))

    # ------------------------------------------------------------------ helpers
    def _phase_state(self, k: int, phase: int, i: int) -> int:
        text = self._phases[k][phase][2]
        pos = int(self._position[i])
        if pos < 0 or pos >= len(text):
            return OFF
        return SUMO_CHARS.get(text[pos], OFF)

    def _set(self, i: int, state: int) -> None:
        if self.states[i] == state:
            return
        previous = STATES[int(self.states[i])]
        self.states[i] = state
        k = int(self._owner[i])
        self.world.events.emit(
            self.world.t_s,
            "traffic_light",
            self.ids[i],
            state=STATES[state],
            previous=previous,
            intersection=self.intersections[k].id,
            mode=self._programs[k].mode,
        )

    def _update_mask(self) -> None:
        self.stop_mask = np.isin(self.states, STOP_STATES)

    def _intersection(self, intersection_id: str) -> int:
        for k, inter in enumerate(self.intersections):
            if inter.id == intersection_id:
                return k
        raise KeyError(f"no intersection '{intersection_id}'")

    def _emit_warning(self, source: str, message: str) -> None:
        self.world.events.emit(self.world.t_s, "warning", source, message=message)
