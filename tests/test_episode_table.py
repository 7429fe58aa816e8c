"""The native LCT batch's ended episodes as one `EpisodeTable`: the rows equal the single
env's `episode_metrics`, and `info["episode_metrics"]` built from the tables equals the
arrays built from per-episode dicts, in one shard, thread shards and process shards."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.vector.env import _metrics_arrays
from opends_gym.vector.episode_rows import table_rows

from .test_vector_native import LCT, SHORT, lct_driver

KW = {**SHORT[LCT], "max_episode_s": 8.0}


def _same_value(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _run(env: Any, steps: int, seed: int, on_end: Any) -> None:
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(lct_driver(obs, rng, env.num_envs))
        if (terminated | truncated).any():
            on_end(np.flatnonzero(terminated | truncated).tolist(), info)


def test_table_rows_equal_the_template_envs_metrics() -> None:
    """Ended episodes that passed signs and that passed none (off the road early): each row
    of `episodes_table` has the keys and the floats of the single env's own `episode_metrics` (scored by the template env's code),
    and `episodes_metrics` gives the same dicts, keys in the same order."""
    env = gym.make_vec(LCT, num_envs=5, vectorization_mode="vector_entry_point", threads=1, **KW)
    core = env.unwrapped.shards[0].core
    seen = {"rows": 0, "signs": 0}

    def check(ended: list[int], info: dict[str, Any]) -> None:
        table = core.episodes_table(ended)
        assert table.values.dtype == np.float64 and table.values.shape == (len(ended), len(table.keys))
        rows = table_rows(table)
        for e, row, (e2, again) in zip(ended, rows, core.episodes_metrics(ended), strict=True):
            want = core.episode_metrics(e)  # the template env's scoring
            assert e2 == e and list(again) == list(want) and set(row) == set(want), e
            for key, value in want.items():
                assert _same_value(row[key], value), (e, key, row[key], value)
                assert _same_value(again[key], value)
            seen["signs"] += "sign00_latency_s" in row
        seen["rows"] += len(ended)

    _run(env, 200, 5, check)
    env.close()
    assert seen["rows"] >= 5 and seen["signs"] >= 2


def test_absent_keys_give_present_false() -> None:
    """Rows of different sign counts on one step: `present` marks each row's own keys, and
    the info arrays keep `_metrics_arrays`' order, masks and zeros for absent keys."""
    env = gym.make_vec(LCT, num_envs=4, vectorization_mode="vector_entry_point", threads=1, **{**KW, "max_episode_s": 40.0})
    core = env.unwrapped.shards[0].core
    rng = np.random.default_rng(1)
    obs, _ = env.reset(seed=1)
    for _ in range(200):  # cars 1-3 pass two signs, car 0 (at random, off the road again and again) none
        obs, *_ = env.step(lct_driver(obs, rng, 4))
    table = core.episodes_table([0, 1, 2, 3])  # (scores the episodes so far: env 0's passed no sign, the others some)
    rows = table_rows(table)
    assert table.present is not None and len({len(r) for r in rows}) >= 2
    for j, (e, again) in enumerate(core.episodes_metrics([0, 1, 2, 3])):
        want = core.episode_metrics(e)
        assert list(again) == list(want) and set(rows[j]) == set(want)  # (the table's keys: in order of first appearance)
        assert table.present[j].tolist() == [k in want for k in table.keys]
        assert all(_same_value(rows[j][k], v) for k, v in want.items())
        assert (table.values[j][~table.present[j]] == 0.0).all()
    env.close()


@pytest.mark.parametrize("shards", [{"threads": 1}, {"threads": 2}, {"processes": 2}])
def test_info_episode_metrics_as_from_dicts(shards: dict[str, int]) -> None:
    """info["episode_metrics"] through one shard, thread shards and process shards equals
    `_metrics_arrays` of the single env's metric dicts: same keys in the same order, dtypes,
    masks and values."""
    env = gym.make_vec(LCT, num_envs=5, vectorization_mode="vector_entry_point", **shards, **KW)
    ref = gym.make_vec(LCT, num_envs=5, vectorization_mode="vector_entry_point", threads=1, **KW)
    ref_core = ref.unwrapped.shards[0].core
    infos: list[dict[str, Any]] = []
    _run(env, 120, 3, lambda ended, info: infos.append(info))
    wants: list[dict[str, Any]] = []
    _run(ref, 120, 3, lambda ended, info: wants.append(_metrics_arrays([(e, ref_core.episode_metrics(e)) for e in ended], 5)))
    env.close()
    ref.close()
    assert len(infos) == len(wants) >= 3
    for info, want in zip(infos, wants, strict=True):
        got = info["episode_metrics"]
        assert list(got) == list(want)
        for key, value in want.items():
            assert got[key].dtype == value.dtype, key
            np.testing.assert_array_equal(got[key], value, err_msg=key)


def test_parallel_scoring_pass_equals_its_serial_twin_and_the_template() -> None:
    """A batch of more than one chunk scores its ended episodes on numba's threads
    (`lct_score_pass.lct_score_episodes`, each episode read straight from the trace ring):
    the same table, bit for bit, as the serial twin, and the template env's floats."""
    from opends_gym.vector.kernels import CHUNK_ENVS

    n = 2 * CHUNK_ENVS + 3
    env = gym.make_vec(LCT, num_envs=n, vectorization_mode="vector_entry_point", threads=1, **KW)
    core = env.unwrapped.shards[0].core
    assert core.parallel
    rng = np.random.default_rng(7)
    env.reset(seed=7)
    scored = 0
    for _ in range(90):  # random steering: cars leave the road at different steps; the rest end at 8 s
        a = np.stack([rng.uniform(-0.25, 0.25, n), rng.uniform(-0.2, 1.0, n)], axis=1).astype(np.float32)
        *_, terminated, truncated, _ = env.step(a)
        ended = np.flatnonzero(terminated | truncated).tolist()
        if not ended:
            continue
        fast = core.episodes_table(ended)
        core.parallel = False
        slow = core.episodes_table(ended)
        core.parallel = True
        assert fast.keys == slow.keys and fast.values.tobytes() == slow.values.tobytes()
        for e, row in zip(ended[:12], table_rows(fast), strict=False):  # (the template's code is slow: a dozen per step)
            want = core.episode_metrics(e)
            assert set(row) == set(want) and all(_same_value(row[k], v) for k, v in want.items()), e
        scored += len(ended)
    env.close()
    assert scored >= n
