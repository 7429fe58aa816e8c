"""The platoon and brake batches hand ended episodes' metrics over as one table (`EpisodeTable`) whose rows are the single env's
`episode_metrics`."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.vector.core import BatchCore
from opends_gym.vector.episode_table import EpisodeTable
from tests.test_vector_native import BRAKE, PLATOON, SHORT, follow_driver


def _drivers(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """`follow_driver`, but env 0 drives full throttle into the lead car and env 1 steers at random."""
    a = follow_driver(obs, rng, n)
    a[0, 0], a[0, 1] = 0.0, 1.0
    a[1, 0] = rng.uniform(-0.4, 0.4)
    return a


def _same_as_dicts(tab: EpisodeTable, rows: list[tuple[int, dict[str, float]]], es: list[int]) -> None:
    assert [e for e, _ in rows] == es and tab.values.shape == (len(es), len(tab.keys)) and tab.values.dtype == np.float64
    for j, (e, d) in enumerate(rows):
        assert tuple(d) == tab.keys, f"env {e}: keys differ"
        present = tab.present[j] if tab.present is not None else np.ones(len(tab.keys), dtype=bool)
        want = np.array([d[k] for k in tab.keys], dtype=np.float64)
        assert present.all() and np.array_equal(tab.values[j], want, equal_nan=True), (e, tab.values[j], want)


def _check(env_id: str, steps: int) -> dict[str, int]:
    """Steps 5 envs; at every step where episodes end, and at the end for every env's episode so
    far (stimuli whose window is over but unscored count as misses), compares `episodes_table`
    with the template's own `episode_metrics` (`BatchCore.episodes_metrics`)."""
    env = gym.make_vec(env_id, num_envs=5, vectorization_mode="vector_entry_point", **SHORT[env_id])
    core: Any = env.unwrapped.shards[0].core  # type: ignore[attr-defined]
    seen = {"ended": 0, "collided": 0, "stimuli": 0}
    table = core.episodes_table  # (the vector env's shards call it for every step's ended episodes)

    def both(es: list[int]) -> Any:
        tab = table(es)
        rows = BatchCore.episodes_metrics(core, es)
        _same_as_dicts(tab, rows, es)
        seen["ended"] += len(es)
        seen["collided"] += sum(1 for _, d in rows if d["collisions"] > 0)
        seen["stimuli"] += sum(1 for _, d in rows if d["stimuli_presented"] > 0)
        return tab

    core.episodes_table = both
    rng = np.random.default_rng(5)
    obs, _ = env.reset(seed=3)
    for _ in range(steps):
        obs, *_ = env.step(_drivers(obs, rng, 5))
    core.episodes_table = table
    last = list(range(5))
    both(last)
    _same_as_dicts(table(last), core.episodes_metrics(last), last)  # (the batch's own dicts are the table's rows)
    assert core.episodes_table([]).values.shape == (0, len(core.episodes_table([]).keys))
    env.close()
    return seen


def test_brake_episode_table_equals_the_single_envs_metrics() -> None:
    seen = _check(BRAKE, 330)
    assert seen["ended"] >= 8 and seen["collided"] >= 1 and seen["stimuli"] >= 2, seen


def test_platoon_episode_table_equals_the_single_envs_metrics() -> None:
    seen = _check(PLATOON, 260)
    assert seen["ended"] >= 8 and seen["collided"] >= 1 and seen["stimuli"] >= 2, seen
