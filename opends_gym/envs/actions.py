"""Action types: how an agent's action becomes `DriverControls`, chosen by name.

Why: RL users want `[steering, pedal]` in [-1, 1]; reaction studies need buttons; planners
want meta-actions. Each type is a small class with `space()` and `to_controls()`,
registered in `ACTION_TYPES` (no if/elif chains).

Conventions: steering + turns left (OpenDS); pedal > 0 accelerates, < 0 brakes.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ..drivers.control import speed_pedal, stanley_steering
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


def _check_finite(action: np.ndarray) -> np.ndarray:
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"action contains NaN or infinity: {a.tolist()}")
    return np.clip(a, -1.0, 1.0)


class ContinuousAction(ActionType):
    """Box [-1, 1]^2: steering (+ left), pedal (+ throttle, - brake)."""

    name = "continuous"

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)

    def to_controls(self, action: Any) -> DriverControls:
        a = _check_finite(action)
        pedal = float(a[1])
        return DriverControls(steering=float(a[0]), accelerator=max(pedal, 0.0), brake=max(-pedal, 0.0))


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
        a = _check_finite(action)
        c = super().to_controls(a[:2])
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
        if isinstance(action, np.ndarray):
            action = action.item()
        a = int(action)
        if not 0 <= a < 5:
            raise ValueError(f"discrete action must be 0..4, got {action!r}")
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
        return DriverControls(steering=steer, accelerator=max(pedal, 0.0), brake=max(-pedal, 0.0))


ACTION_TYPES: dict[str, type[ActionType]] = {t.name: t for t in (ContinuousAction, ContinuousButtonsAction, DiscreteAction)}


def make_action_type(name: str, world: World, guide: RoadGuide, config: Any) -> ActionType:
    try:
        cls = ACTION_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown action type {name!r}; choose from {', '.join(ACTION_TYPES)}") from None
    return cls(world, guide, config)


__all__ = ["ACTION_TYPES", "BUTTONS", "ActionType", "make_action_type"]
