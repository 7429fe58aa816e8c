"""A parameterised distracted-driver model that wraps any driver.

Why: distraction metrics (MDEV, SDLP, reversal rate, brake reaction time, DRT hit rate)
are validated by showing they move with distraction. This model dials distraction up
with four documented mechanisms, each a parameter:

* **secondary-task duty cycle** `duty_cycle`: the fraction of time the driver is busy
  with a visual-manual secondary task. Task episodes last `task_episode_s` on average
  (exponential), with gaps drawn so the long-run busy fraction is the duty cycle;
* **glances away** while busy: off-road glances (log-normal, mean `glance_mean_s`, sd
  `glance_sd_s`) alternate with on-road glances (log-normal, mean `on_road_glance_s`).
  During an off-road glance the driver acts on the **stale percept** from the moment the
  eyes left the road: steering and pedals follow a frozen world, so the car drifts and
  stimuli go unnoticed until the eyes return. Drivers defer a glance that would start in
  the middle of a manoeuvre (a lane change under way), as observed drivers do (Schömig &
  Metz 2013, "Three levels of situation awareness in driving with secondary tasks");
* **perception-reaction delay** `reaction_delay_s`: discrete stimuli (a sign's
  instruction, a brake stimulus, a light, a DRT stimulus) reach the driver this much later
  than they appear; continuous lane keeping uses what the eyes see now. Even the `none`
  level has a human's 0.35 s (simple reaction times to an expected stimulus, as in
  detection response tasks, are about 0.3-0.4 s); the distracted levels add 0.2, 0.4 and
  0.7 s. (The bare rule driver reacts at its next decision.)
* **steering noise** `steering_noise_sd`: Gaussian noise (steering input units, 1 = 450
  degrees of wheel) added to every steering command.

The levels are our documented choice, anchored in published figures: off-road glances
of visual-manual tasks average about 1-2 s, and glances over 2 s double near-crash risk
(Klauer et al. 2006, the 100-car study; NHTSA's 2013 visual-manual guidelines use 2 s per
glance and 12 s in total as limits); brake reaction times grow by several hundred
milliseconds under distraction (Green 2000; Horrey & Wickens 2006 meta-analysis).

Drivers with a `decide(percept)` method (the rule driver) are distracted at the percept
level as above. Any other driver (a trained policy) is distracted at the observation
level: it sees a frozen observation during off-road glances.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

import gymnasium as gym
import numpy as np

from .intent import to_action
from .percept import Percept, perceive
from .rule import RuleDriver, start_engine


@dataclass(frozen=True)
class DistractionParams:
    """See the module docstring. All times in seconds."""

    duty_cycle: float = 0.0
    task_episode_s: float = 8.0
    glance_mean_s: float = 1.2
    glance_sd_s: float = 0.5
    on_road_glance_s: float = 1.0
    reaction_delay_s: float = 0.0
    steering_noise_sd: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.duty_cycle < 1.0:
            raise ValueError(f"duty_cycle must be in [0, 1), got {self.duty_cycle}")
        for name in ("task_episode_s", "glance_mean_s", "on_road_glance_s"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"{name} must be positive")
        if self.glance_sd_s < 0 or self.reaction_delay_s < 0 or self.steering_noise_sd < 0:
            raise ValueError("glance_sd_s, reaction_delay_s and steering_noise_sd must be >= 0")


ATTENTIVE_REACTION_S = 0.35
LEVELS: dict[str, DistractionParams] = {
    "none": DistractionParams(reaction_delay_s=ATTENTIVE_REACTION_S),
    "light": DistractionParams(duty_cycle=0.2, glance_mean_s=0.8, glance_sd_s=0.3, reaction_delay_s=0.55, steering_noise_sd=0.002),
    "moderate": DistractionParams(duty_cycle=0.4, glance_mean_s=1.2, glance_sd_s=0.5, reaction_delay_s=0.75, steering_noise_sd=0.004),
    "heavy": DistractionParams(duty_cycle=0.7, glance_mean_s=1.8, glance_sd_s=0.7, reaction_delay_s=1.05, steering_noise_sd=0.008),
}
LEVEL_ORDER = ("none", "light", "moderate", "heavy")


def params_for(level: str) -> DistractionParams:
    """A named level, or a number 0..1 interpolating between none (0) and heavy (1)."""
    if level in LEVELS:
        return LEVELS[level]
    try:
        x = float(level)
    except ValueError:
        raise ValueError(f"unknown distraction level {level!r}; use {', '.join(LEVEL_ORDER)} or a number in [0, 1]") from None
    if not 0.0 <= x <= 1.0 or math.isnan(x):
        raise ValueError(f"distraction level must be in [0, 1], got {x}")
    lo, hi = LEVELS["none"], LEVELS["heavy"]
    return DistractionParams(
        duty_cycle=x * hi.duty_cycle,
        glance_mean_s=lo.glance_mean_s + x * (hi.glance_mean_s - lo.glance_mean_s),
        glance_sd_s=lo.glance_sd_s + x * (hi.glance_sd_s - lo.glance_sd_s),
        reaction_delay_s=lo.reaction_delay_s + x * (hi.reaction_delay_s - lo.reaction_delay_s),
        steering_noise_sd=x * hi.steering_noise_sd,
    )


def _lognormal(rng: np.random.Generator, mean: float, sd: float) -> float:
    if sd <= 0.0:
        return mean
    sigma2 = math.log(1.0 + (sd / mean) ** 2)
    return float(rng.lognormal(math.log(mean) - 0.5 * sigma2, math.sqrt(sigma2)))


class GlanceProcess:
    """When the eyes are off the road (simulation time), from a seeded RNG."""

    def __init__(self, params: DistractionParams, rng: np.random.Generator) -> None:
        self.p = params
        self.rng = rng
        self.busy = False
        self.off_road = False
        self.busy_until = 0.0
        self.idle_until = self._idle_duration(0.0)
        self.glance_until = 0.0

    def _idle_duration(self, now: float) -> float:
        p = self.p
        if p.duty_cycle <= 0.0:
            return math.inf
        idle_mean = p.task_episode_s * (1.0 - p.duty_cycle) / p.duty_cycle
        return now + float(self.rng.exponential(idle_mean))

    def eyes_off_road(self, t_s: float, may_look_away: bool = True) -> bool:
        """Advance to `t_s` and say whether the driver is looking away now. A glance due
        while `may_look_away` is false is deferred until it is true."""
        p = self.p
        while True:
            if not self.busy:
                if t_s < self.idle_until:
                    self.off_road = False
                    return False
                if not may_look_away:
                    self.idle_until = t_s + 1e-9
                    return False
                self.busy, self.busy_until = True, self.idle_until + float(self.rng.exponential(p.task_episode_s))
                self.off_road, self.glance_until = True, self.idle_until + _lognormal(self.rng, p.glance_mean_s, p.glance_sd_s)
                continue
            if t_s >= self.busy_until:  # the task is done: eyes back on the road
                self.busy = self.off_road = False
                self.idle_until = self._idle_duration(self.busy_until)
                continue
            if t_s < self.glance_until:
                return self.off_road
            start = self.glance_until
            if self.off_road:
                self.off_road, self.glance_until = False, start + _lognormal(self.rng, p.on_road_glance_s, 0.3 * p.on_road_glance_s)
            elif not may_look_away:
                self.glance_until = t_s + 1e-9
                return False
            else:
                self.off_road, self.glance_until = True, start + _lognormal(self.rng, p.glance_mean_s, p.glance_sd_s)


# a lane change is under way while the car is farther than this from where the driver
# means to be, or heading across the road by more than this
MANOEUVRE_OFFSET_M = 0.5
MANOEUVRE_HEADING_RAD = 0.02

# percept fields that carry discrete stimuli (delayed by the reaction delay)
_STIMULUS_FIELDS = (
    "target_lateral_m",
    "lane_change_pending",
    "sign_distance_m",
    "brake_to_mps",
    "brake_hard",
    "press_reaction",
    "drt_onset_s",
)


class DistractedDriver:
    """Wraps a driver (default: the rule driver) with the distraction mechanisms."""

    def __init__(self, params: DistractionParams | str = "moderate", base: Any = None) -> None:
        self.params = params_for(params) if isinstance(params, str) else params
        self.base = base if base is not None else RuleDriver()
        self.name = f"distracted({getattr(self.base, 'name', 'driver')})"
        self.off_road_s = 0.0

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.env = env
        self.base.reset(env, seed)
        self.rng = np.random.default_rng([int(seed), 0x0D15])
        self.glances = GlanceProcess(self.params, self.rng)
        self._history: deque[Percept] = deque()
        self._stale: Any = None
        self.off_road_s = 0.0
        self._last_t: float | None = None

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        t = float(self.env.unwrapped.world.t_s)  # type: ignore[attr-defined]
        if hasattr(self.base, "decide"):
            now = perceive(self.env, info)
            start_engine(self.env, now)  # (the key is turned whatever the eyes do)
            settled = abs(now.target_lateral_m - now.lateral_m) < MANOEUVRE_OFFSET_M and abs(now.heading_error_rad) < MANOEUVRE_HEADING_RAD
            off = self._eyes_off(t, settled or self._stale is not None)
            return self._act_on_percept(now, off)
        off = self._eyes_off(t, True)
        if off:
            self._stale = obs if self._stale is None else self._stale
            return self.base.act(self._stale, info)
        self._stale = None
        return self.base.act(obs, info)

    def _eyes_off(self, t: float, may_look_away: bool) -> bool:
        off = self.glances.eyes_off_road(t, may_look_away)
        if self._last_t is not None and off:
            self.off_road_s += t - self._last_t
        self._last_t = t
        return off

    def _act_on_percept(self, now: Percept, off: bool) -> Any:
        self._history.append(now)
        while len(self._history) > 1 and self._history[1].t_s <= now.t_s - self.params.reaction_delay_s + 1e-9:
            self._history.popleft()
        delayed = self._history[0]
        seen = replace(now, **{f: getattr(delayed, f) for f in _STIMULUS_FIELDS})
        if delayed.contre is not None and now.contre is not None:
            seen = replace(seen, contre=(now.contre[0], now.contre[1], delayed.contre[2]))
        if off:
            if self._stale is None:
                self._stale = seen
            seen = self._stale
        else:
            self._stale = None
        intent = self.base.decide(seen)
        if self.params.steering_noise_sd > 0.0:
            noise = float(self.rng.normal(0.0, self.params.steering_noise_sd))
            intent = replace(intent, steering=max(-1.0, min(1.0, intent.steering + noise)))
        return to_action(self.env, intent)
