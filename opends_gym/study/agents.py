"""The driver of one virtual trial, from its agent spec.

Why: `participant:ID:LOAD` must give participant ID of *this study's* population (drawn with
the study's seed by `drivers.population.sample_population`), not of some default population;
every other spec (`distracted:heavy`, `rule`, `ppo:NAME`) is `drivers.agents.make_agent`'s.
"""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym

from ..drivers.agents import make_agent
from ..drivers.participant import ParticipantDriver
from ..drivers.population import ParticipantParams, sample_population
from ..errors import UserError


@functools.lru_cache(maxsize=4)
def population(n: int, seed: int) -> tuple[ParticipantParams, ...]:
    """The study's participants' parameters, drawn once per process (seeded: the same in every worker)."""
    return tuple(sample_population(n, seed))


class StudyParticipant:
    """Participant `index` of the study's population under `load`, built per episode (it needs the env)."""

    def __init__(self, params: ParticipantParams, load: str) -> None:
        self.params = params
        self.load = load
        self.name = f"participant:{load}"
        self.driver: ParticipantDriver | None = None

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.driver = ParticipantDriver(env, self.params, self.load, seed)
        self.driver.reset(env, seed)

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        assert self.driver is not None, "reset() first"
        return self.driver.act(obs, info)

    @property
    def glances(self) -> list[tuple[float, float]] | None:
        """The driver's off-road glances: `run_episode` turns them into the glance metrics."""
        return self.driver.glances if self.driver is not None else None


class CheckedAgent:
    """An agent whose `reset` refusal (a policy or clone made for another observation) is a
    one-line UserError naming the spec, as `opends-gym run --agent` gives it."""

    def __init__(self, agent: Any, spec: str, where: str = "") -> None:
        self.agent = agent
        self.spec = spec
        self.where = where  # e.g. "condition X, task Y: " before the message
        self.name = getattr(agent, "name", spec)
        self.act = agent.act

    def __getattr__(self, name: str) -> Any:  # (the agent's other attributes, its `glances` for one)
        agent = self.__dict__.get("agent")
        if agent is None:
            raise AttributeError(name)
        return getattr(agent, name)

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        try:
            self.agent.reset(env, seed)
        except ValueError as e:
            raise UserError(f"{self.where}agent {self.spec}: {e}") from None


def make_trial_agent(spec: str, participants: int, seed: int, where: str = "") -> Any:
    """`spec` -> agent; `participant:ID[:LOAD]` is participant ID of the study's population
    (`where`: the trial, for a one-line refusal at reset)."""
    name, _, rest = spec.partition(":")
    if name == "participant":
        index_text, _, load = rest.partition(":")
        index = int(index_text)
        return StudyParticipant(population(participants, seed)[index], load or "baseline")
    return CheckedAgent(make_agent(spec), spec, where)
