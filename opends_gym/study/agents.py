"""The driver of one virtual trial, from its agent spec.

Why: `participant:ID:LOAD` must give participant ID of *this study's* population (drawn with
the study's seed by `drivers.population.sample_population`), not of some default population;
every other spec (`distracted:heavy`, `rule`, `ppo:NAME`) is `drivers.agents.make_agent`'s.
"""

from __future__ import annotations

import functools
import importlib
from typing import Any

import gymnasium as gym

from ..drivers.agents import make_agent

POPULATION_MODULE = "opends_gym.drivers.population"
PARTICIPANT_MODULE = "opends_gym.drivers.participant"


def population_available() -> bool:
    """Whether the virtual participant model (drivers.population / drivers.participant) is installed."""
    try:
        importlib.import_module(POPULATION_MODULE)
        importlib.import_module(PARTICIPANT_MODULE)
    except ImportError:
        return False
    return True


@functools.lru_cache(maxsize=4)
def population(n: int, seed: int) -> tuple[Any, ...]:
    """The study's participants' parameters, drawn once per process (seeded: the same in every worker)."""
    module = importlib.import_module(POPULATION_MODULE)
    return tuple(module.sample_population(n, seed))


class StudyParticipant:
    """Participant `index` of the study's population under `load`, built per episode (it needs the env)."""

    def __init__(self, params: Any, load: str) -> None:
        self.params = params
        self.load = load
        self.name = f"participant:{load}"
        self.driver: Any = None

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        cls = importlib.import_module(PARTICIPANT_MODULE).ParticipantDriver
        self.driver = cls(env, self.params, self.load, seed)
        if hasattr(self.driver, "reset"):
            self.driver.reset(env, seed)

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        return self.driver.act(obs, info)


def make_trial_agent(spec: str, participants: int, seed: int) -> Any:
    """`spec` -> agent; `participant:ID[:LOAD]` draws from the study's population when the model is installed."""
    name, _, rest = spec.partition(":")
    if name == "participant" and not population_available():
        raise ValueError(
            "the virtual participant model (opends_gym.drivers.population) is not installed; give the condition an"
            " 'agent:' or the study 'stand_in_agents:' (e.g. distracted:moderate)"
        )
    if name == "participant":
        index_text, _, load = rest.partition(":")
        index = int(index_text)
        return StudyParticipant(population(participants, seed)[index], load or "baseline")
    return make_agent(spec)
