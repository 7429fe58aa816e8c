"""Agents that `opends-gym run` (and benchmarks) can drive an env with, by spec string.

Why: one place turns `--agent random`, `constant:0,0.5`, `rule`, `distracted:heavy`, `participant:7:cognitive` or
`ppo:PATH` or `bc:FOLDER` into an object with `reset(env, seed)` and `act(obs, info)`, so the CLI, the
benchmarks and the tests run every driver the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from ..hints import did_you_mean


class Agent(Protocol):
    name: str

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None: ...

    def act(self, obs: Any, info: dict[str, Any]) -> Any: ...


class RandomAgent:
    """Uniform random actions from the env's action space, seeded per episode."""

    name = "random"

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.space = env.action_space
        self.space.seed(seed)

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        return self.space.sample()


class ConstantAgent:
    """The same action every step (`constant:STEER,PEDAL`, default straight at half throttle)."""

    name = "constant"

    def __init__(self, values: tuple[float, ...] = (0.0, 0.5)) -> None:
        self.values = values

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        space = env.action_space
        if isinstance(space, gym.spaces.Discrete):
            self.action: Any = int(self.values[0]) if self.values else 0
            return
        a = np.zeros(tuple(space.shape or ()), dtype=np.float32)
        a[: len(self.values)] = self.values[: a.size]
        self.action = a

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        return self.action


def _rule(arg: str) -> Agent:
    from .rule import RuleDriver

    if arg:
        raise ValueError("the rule driver takes no argument")
    return RuleDriver()


def _distracted(arg: str) -> Agent:
    from .distracted import DistractedDriver

    return DistractedDriver(arg or "moderate")


def _participant(arg: str) -> Agent:
    """`participant:ID` or `participant:ID:LOAD`: participant ID of the standard population."""
    from .participant import ParticipantDriver
    from .population import LOADS, POPULATION_SEED, draw_participant

    ident, _, load = arg.partition(":")
    if not ident.isdigit():
        raise ValueError(f"give a participant number: participant:ID[:LOAD] with LOAD one of {', '.join(LOADS)}, not {arg!r}")
    load = load or "baseline"
    if load not in LOADS:
        raise ValueError(f"unknown load {load!r}{did_you_mean(load, LOADS)}; use one of {', '.join(LOADS)}")
    return ParticipantDriver(None, draw_participant(int(ident), POPULATION_SEED), load)


def _policy(algorithm: str) -> Callable[[str], Agent]:
    def make(arg: str) -> Agent:
        from .policy import PolicyDriver

        if not arg:
            raise ValueError(f"give the saved model: {algorithm}:PATH")
        return PolicyDriver(algorithm, arg)

    return make


def _bc(arg: str) -> Agent:
    """`bc:NAME`: a behaviour clone saved by `opends-gym train bc` (folder) or bundled by name."""
    from .bc import BCDriver

    if not arg:
        raise ValueError("give the saved clone: bc:FOLDER (from opends-gym train bc)")
    return BCDriver(arg)


AGENT_FACTORIES: dict[str, Callable[[str], Agent]] = {
    "random": lambda arg: RandomAgent(),
    "constant": lambda arg: ConstantAgent(tuple(float(v) for v in arg.split(",")) if arg else (0.0, 0.5)),
    "rule": _rule,
    "distracted": _distracted,
    "participant": _participant,
    "ppo": _policy("ppo"),
    "sac": _policy("sac"),
    "bc": _bc,
}


def make_agent(spec: str) -> Agent:
    """`name[:argument]` -> agent; raises ValueError listing the known names."""
    name, _, arg = spec.partition(":")
    factory = AGENT_FACTORIES.get(name)
    if factory is None:
        hint = did_you_mean(name, AGENT_FACTORIES)
        raise ValueError(f"unknown agent {name!r}{hint} (known: {', '.join(sorted(AGENT_FACTORIES))})")
    return factory(arg)
