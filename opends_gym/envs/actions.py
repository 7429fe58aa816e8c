"""Action types: how an agent's action becomes `DriverControls`, chosen by name.

Why: RL users want `[steering, pedal]` in [-1, 1]; reaction studies need buttons; planners
want meta-actions. Each type is a small class with `space()` and `to_controls()`,
registered in `ACTION_TYPES` (no if/elif chains).

Conventions: steering + turns left (OpenDS); pedal > 0 accelerates, < 0 brakes.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from ..control.controllers import speed_pedal, stanley_steering
from ..sim.controls import DriverControls
from ..sim.guide import RoadGuide
from ..sim.world import World


class ActionType:
    """Base class: subclasses set `name` and implement `space` and `to_controls`."""

    name = ""

    def __init__(self, world: World, guide: RoadGuide, config: Any) -> None:
        self.world = world
        self.guide = guide
        self.config = config

    def space(self) -> gym.spaces.Space[Any]:
        raise NotImplementedError

    def reset(self) -> None:
        """Forget per-episode state (meta-action targets, button edges)."""

    def to_controls(self, action: Any) -> DriverControls:
        raise NotImplementedError


def _flat(action: Any, size: int, kind: str) -> np.ndarray:
    """The action as `size` floats; a wrong length is an error (extras were silently dropped)."""
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"a {kind} action is {size} numbers (shape ({size},)), got {action!r:.80}") from None
    if a.shape != (size,):
        raise ValueError(f"a {kind} action has shape ({size},), got {a.shape}")
    return a


def _check_finite(action: Any, size: int, kind: str) -> np.ndarray:
    a = _flat(action, size, kind)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"action contains NaN or infinity: {a.tolist()}")
    return np.clip(a, -1.0, 1.0)


def _whole(action: Any) -> int | None:
    """A discrete action as an int: one integer, or one float with an integral value; else None."""
    if isinstance(action, np.ndarray) and action.size == 1:
        action = action.item()
    if isinstance(action, (bool, np.bool_)) or not isinstance(action, (int, np.integer, float, np.floating)):
        return None
    if isinstance(action, (float, np.floating)) and not (math.isfinite(action) and float(action).is_integer()):
        return None
    return int(action)


class ContinuousAction(ActionType):
    """Box [-1, 1]^2: steering (+ left), pedal (+ throttle, - brake)."""

    name = "continuous"

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)

    def to_controls(self, action: Any) -> DriverControls:
        if type(action) is np.ndarray and action.shape == (2,) and action.dtype.kind == "f":
            values = action.tolist()  # plain floats: cheaper than array maths here
        else:
            values = _flat(action, 2, self.name).tolist()
        if not all(map(math.isfinite, values)):
            raise ValueError(f"action contains NaN or infinity: {values}")
        steering, pedal = (-1.0 if v < -1.0 else 1.0 if v > 1.0 else v for v in values[:2])
        return DriverControls.pedals(steering, max(pedal, 0.0), max(-pedal, 0.0))


BUTTONS = ("reaction", "horn", "indicator_left", "indicator_right")


class ContinuousButtonsAction(ContinuousAction):
    """Box [-1, 1]^6: steering, pedal, then buttons reaction, horn, left and right indicator.

    A button is pressed when its value rises above 0 (a press is an edge, as a real key);
    `reaction` presses the task's reaction key (`config.extra["reaction_key"]`, default
    KEY_RETURN) and joystick button 0, which feed pressKey/pressButton triggers, key
    reaction timers and the DRT wrapper.
    """

    name = "continuous_buttons"

    def __init__(self, world: World, guide: RoadGuide, config: Any) -> None:
        super().__init__(world, guide, config)
        self.reaction_key = str(config.extra.get("reaction_key", "KEY_RETURN"))
        self._held = [False] * len(BUTTONS)

    def reset(self) -> None:
        self._held = [False] * len(BUTTONS)

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-1.0, 1.0, shape=(2 + len(BUTTONS),), dtype=np.float32)

    def to_controls(self, action: Any) -> DriverControls:
        a = _check_finite(action, 2 + len(BUTTONS), self.name)
        c = ContinuousAction.to_controls(self, a[:2])
        down = [bool(v > 0.0) for v in a[2:]]
        pressed = [d and not h for d, h in zip(down, self._held)]
        self._held = down
        if pressed[0]:
            c.keys = (self.reaction_key,)
            c.buttons = (0,)
        c.horn = down[1]
        if down[2] and not down[3]:
            c.turn_signal = "left"
        elif down[3] and not down[2]:
            c.turn_signal = "right"
        else:
            c.turn_signal = "off"
        return c


class DiscreteAction(ActionType):
    """Discrete(5) meta-actions: 0 keep, 1 lane left, 2 lane right, 3 faster, 4 slower.

    A Stanley lane keeper and a speed controller execute them; the speed step is
    `config.extra["speed_step_mps"]` (default 10 km/h).
    """

    name = "discrete"
    KEEP, LEFT, RIGHT, FASTER, SLOWER = range(5)

    def __init__(self, world: World, guide: RoadGuide, config: Any) -> None:
        super().__init__(world, guide, config)
        self.speed_step = float(config.extra.get("speed_step_mps", 10.0 / 3.6))
        self.reset()

    def space(self) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(5)

    def reset(self) -> None:
        s = self.world.ego.state
        p = self.guide.locate(s.x, s.z)
        self.target_lane = self.guide.nearest_lane(p.lateral_m)
        engine = self.world.task.scenario.driver.car.engine
        self.target_speed = max(abs(s.u), min(engine.max_speed_mps, 50.0 / 3.6))

    def to_controls(self, action: Any) -> DriverControls:
        a = _whole(action)
        if a is None or not 0 <= a < 5:
            raise ValueError(f"discrete action must be one whole number 0..4, got {action!r:.80}")
        lats = self.guide.lane_laterals_m
        current = lats[self.target_lane]
        if a == self.LEFT:
            left = [i for i, v in enumerate(lats) if v > current + 1e-6]
            if left:
                self.target_lane = min(left, key=lambda i: lats[i])
        elif a == self.RIGHT:
            right = [i for i, v in enumerate(lats) if v < current - 1e-6]
            if right:
                self.target_lane = max(right, key=lambda i: lats[i])
        elif a == self.FASTER:
            self.target_speed += self.speed_step
        elif a == self.SLOWER:
            self.target_speed = max(0.0, self.target_speed - self.speed_step)
        s = self.world.ego.state
        p = self.guide.locate(s.x, s.z)
        steer = stanley_steering(s.yaw, p.heading_rad, p.lateral_m, lats[self.target_lane], s.u, s.r)
        pedal = speed_pedal(s.u, self.target_speed)
        return DriverControls.pedals(steer, max(pedal, 0.0), max(-pedal, 0.0))


def _control_keys() -> tuple[str, ...]:
    """jME key names a keyboard can press, plus joystick buttons (JOY_n and BUTTON_n)."""
    names = [f"KEY_{c}" for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"]
    names += [f"KEY_F{n}" for n in range(1, 16)] + [f"KEY_NUMPAD{d}" for d in range(10)]
    names += [
        "KEY_RETURN",
        "KEY_SPACE",
        "KEY_UP",
        "KEY_DOWN",
        "KEY_LEFT",
        "KEY_RIGHT",
        "KEY_PGUP",
        "KEY_PGDN",
        "KEY_HOME",
        "KEY_END",
        "KEY_INSERT",
        "KEY_DELETE",
        "KEY_BACK",
        "KEY_ESCAPE",
        "KEY_TAB",
        "KEY_LSHIFT",
        "KEY_RSHIFT",
        "KEY_LCONTROL",
        "KEY_RCONTROL",
        "KEY_LMENU",
        "KEY_RMENU",
        "KEY_CAPITAL",
        "KEY_PAUSE",
        "KEY_MINUS",
        "KEY_EQUALS",
        "KEY_COMMA",
        "KEY_PERIOD",
        "KEY_SLASH",
        "KEY_BACKSLASH",
        "KEY_SEMICOLON",
        "KEY_APOSTROPHE",
        "KEY_GRAVE",
        "KEY_LBRACKET",
        "KEY_RBRACKET",
        "KEY_NUMPADENTER",
        "KEY_ADD",
        "KEY_SUBTRACT",
        "KEY_MULTIPLY",
        "KEY_DIVIDE",
        "KEY_DECIMAL",
    ]
    names += [f"JOY_{n}" for n in range(64)] + [f"BUTTON_{n}" for n in range(64)]
    return tuple(names)


CONTROL_KEYS = _control_keys()
_SCALARS = ("steering", "accelerator", "brake", "clutch")
_FLAGS = ("shift_up", "shift_down", "hand_brake")
_SIGNALS = ("off", "left", "right", "both")
KEY_SLOTS, BUTTON_SLOTS, REMOTE_SLOTS = 8, 8, 4


class ControlsAction(ActionType):
    """Every `DriverControls` field as one float64 vector: the human runner's action type.

    Why: a human session (keyboard, wheel, CAN) steps the same env as an agent, at
    `policy_hz = physics_hz`, so it gets the same metrics; and its actions must record and
    replay bit for bit like any other action. `to_controls` accepts a `DriverControls`
    directly or this encoding (`encode`), which is what gets recorded.

    Layout (NaN = None / unused): 0 steering, 1 accelerator, 2 brake, 3 clutch, 4 gear,
    5 shift_up, 6 shift_down, 7 hand_brake, 8 engine_on, 9 toggle_automatic,
    10 cruise_control, 11 cruise_speed_delta_mps, 12 turn_signal (0 off, 1 left, 2 right,
    3 both), 13 horn, 14 reset_to (index into the World's reset points),
    15-22 keys (index into `CONTROL_KEYS` + the task's pressKey keys), 23-30 buttons,
    31-34 remote trigger ids (index into the task's sorted `remote:` ids), 35 steering
    source (1 an analogue axis, 0 keyboard or another non-axis source: `steering_axis`;
    recordings made before it have 35 values and read as axis steering). Presses beyond
    the slots in one physics step are dropped (8 keys in 1/60 s is beyond a human).
    """

    name = "controls"
    SIZE = 15 + KEY_SLOTS + BUTTON_SLOTS + REMOTE_SLOTS + 1

    def __init__(self, world: World, guide: RoadGuide, config: Any) -> None:
        super().__init__(world, guide, config)
        from ..task.conditions import PressKey, Remote

        task_keys: set[str] = set()
        remotes: set[str] = set()
        for trig in world.task.interaction.triggers:
            for c in trig.condition.items:
                if isinstance(c, PressKey):
                    task_keys.add(c.key)
                elif isinstance(c, Remote):
                    remotes.add(c.trigger_id)
        self.keys = CONTROL_KEYS + tuple(sorted(task_keys - set(CONTROL_KEYS)))
        self.key_index = {k: i for i, k in enumerate(self.keys)}
        self.remote_ids = tuple(sorted(remotes))
        self.reset_ids = tuple(world.reset_poses)

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-np.inf, np.inf, shape=(self.SIZE,), dtype=np.float64)

    def encode(self, c: DriverControls) -> np.ndarray:
        """The vector for `c` (unknown keys, remote ids and reset points are left out)."""
        from ..task.conditions import canonical_key

        nan = math.nan
        v = np.full(self.SIZE, nan, dtype=np.float64)
        for i, name in enumerate(_SCALARS):
            v[i] = float(getattr(c, name))
        v[4] = nan if c.gear is None else float(c.gear)
        for i, name in enumerate(_FLAGS):
            v[5 + i] = float(bool(getattr(c, name)))
        v[8] = nan if c.engine_on is None else float(c.engine_on)
        v[9] = float(bool(c.toggle_automatic))
        v[10] = nan if c.cruise_control is None else float(c.cruise_control)
        v[11] = float(c.cruise_speed_delta_mps)
        v[12] = nan if c.turn_signal is None else float(_SIGNALS.index(c.turn_signal))
        v[13] = float(bool(c.horn))
        v[14] = nan if c.reset_to not in self.reset_ids else float(self.reset_ids.index(c.reset_to))
        keys = [self.key_index[k] for k in (canonical_key(k) for k in c.keys) if k in self.key_index][:KEY_SLOTS]
        v[15 : 15 + len(keys)] = keys
        buttons = [int(b) for b in c.buttons][:BUTTON_SLOTS]
        v[23 : 23 + len(buttons)] = buttons
        remotes = [self.remote_ids.index(r) for r in c.remote_triggers if r in self.remote_ids][:REMOTE_SLOTS]
        v[31 : 31 + len(remotes)] = remotes
        v[35] = float(bool(c.steering_axis))
        return v

    def to_controls(self, action: Any) -> DriverControls:
        if isinstance(action, DriverControls):
            return DriverControls(**action.__dict__)
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape == (self.SIZE - 1,):  # recorded before the steering source slot
            a = np.append(a, 1.0)
        if a.shape != (self.SIZE,):
            raise ValueError(f"a controls action has {self.SIZE} values, got shape {a.shape}")

        def opt(x: float) -> float | None:
            return None if math.isnan(x) else float(x)

        def idx(values: np.ndarray, table: tuple[str, ...]) -> tuple[str, ...]:
            return tuple(table[int(x)] for x in values if not math.isnan(x) and 0 <= int(x) < len(table))

        gear, engine, cruise, signal, reset = (opt(float(a[i])) for i in (4, 8, 10, 12, 14))
        return DriverControls(
            steering=float(a[0]),
            accelerator=float(a[1]),
            brake=float(a[2]),
            clutch=float(a[3]),
            gear=None if gear is None else int(gear),
            shift_up=bool(a[5] > 0),
            shift_down=bool(a[6] > 0),
            hand_brake=bool(a[7] > 0),
            engine_on=None if engine is None else bool(engine),
            toggle_automatic=bool(a[9] > 0),
            cruise_control=None if cruise is None else bool(cruise),
            cruise_speed_delta_mps=float(a[11]),
            turn_signal=None if signal is None else _SIGNALS[int(signal) % 4],
            horn=bool(a[13] > 0),
            keys=idx(a[15:23], self.keys),
            buttons=tuple(int(x) for x in a[23:31] if not math.isnan(x)),
            remote_triggers=idx(a[31:35], self.remote_ids),
            reset_to=None if reset is None or not 0 <= int(reset) < len(self.reset_ids) else self.reset_ids[int(reset)],
            steering_axis=bool(a[35] != 0.0),  # (NaN: an axis)
        )


ACTION_TYPES: dict[str, type[ActionType]] = {t.name: t for t in (ContinuousAction, ContinuousButtonsAction, DiscreteAction, ControlsAction)}


def make_action_type(name: str, world: World, guide: RoadGuide, config: Any) -> ActionType:
    try:
        cls = ACTION_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown action type {name!r}; choose from {', '.join(ACTION_TYPES)}") from None
    return cls(world, guide, config)


__all__ = ["ACTION_TYPES", "BUTTONS", "ActionType", "make_action_type"]
