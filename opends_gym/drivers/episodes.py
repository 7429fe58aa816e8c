"""Run one episode of an env with a driver: the loop the CLI, training, benchmarks and
evaluation scripts share, so every driver is scored the same way."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym

from ..metrics.glance import glance_metrics


@dataclass
class Episode:
    """What one episode gave: its return, length, end and the env's `episode_metrics`."""

    seed: int
    ret: float
    steps: int
    terminated: bool
    wall_s: float
    metrics: dict[str, Any] = field(default_factory=dict)


def run_episode(env: gym.Env[Any, Any], agent: Any, seed: int) -> Episode:
    """Reset `env` and `agent` with `seed` and drive until the episode ends. An agent with
    a `glances` list (or tuple) of (start_s, end_s) off-road glances (the virtual
    participant) adds the glance metrics of `metrics.glance` (glance_count,
    glance_total_eyes_off_road_s, glance_mean_s, glance_max_s, glance_long_share)."""
    start = time.perf_counter()
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed)
    ret, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        ret += float(reward)
        steps += 1
        if terminated or truncated:
            break
    metrics = with_glances(info.get("episode_metrics", {}), agent)
    return Episode(seed, ret, steps, bool(terminated), time.perf_counter() - start, metrics)


def with_glances(episode_metrics: dict[str, Any], agent: Any) -> dict[str, Any]:
    """The env's episode metrics plus the glance metrics of an agent that lists its glances."""
    metrics = dict(episode_metrics)
    glances = getattr(agent, "glances", None)
    if isinstance(glances, (list, tuple)):  # a driver model's off-road glances: ISO 15007 / NHTSA glance measures
        metrics.update(glance_metrics(glances).as_dict())
    return metrics
