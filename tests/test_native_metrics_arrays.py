"""The native batch's `episode_metrics` arrays: Gymnasium's per-episode `_add_info` layout, built a block at a time."""

from __future__ import annotations

import math

import numpy as np

from opends_gym.vector.env import _add_numbers, _metrics_arrays


def _one_by_one(ended: list[tuple[int, dict[str, float]]], n: int) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for e, values in ended:
        _add_numbers(out, values, e, n)
    return out


def test_episodes_with_different_keys_give_the_one_by_one_arrays() -> None:
    """Episodes of one step whose keys differ (the LCT's per-sign keys: more signs passed,
    more keys) give the same keys in the same order, values, dtypes and masks as adding them
    one episode at a time."""
    ended = [
        (5, {"duration_s": 3.0, "mdev_basic_m": math.nan, "lane_changes": 0.0}),
        (1, {"duration_s": 7.5, "mdev_basic_m": 0.25, "sign00_latency_s": 1.5, "lane_changes": 1.0}),
        (3, {"duration_s": 9.0, "mdev_basic_m": 0.5, "sign00_latency_s": math.nan, "sign01_latency_s": 2.0, "lane_changes": 2.0}),
    ]
    fast, slow = _metrics_arrays(ended, 7), _one_by_one(ended, 7)
    assert list(fast) == list(slow)
    for key, want in slow.items():
        assert fast[key].dtype == want.dtype, key
        np.testing.assert_array_equal(fast[key], want, err_msg=key)
    one = _metrics_arrays(ended[1:2], 7)
    assert list(one) == list(_one_by_one(ended[1:2], 7)) and one["sign00_latency_s"][1] == 1.5 and one["_duration_s"].sum() == 1
    assert fast["_sign01_latency_s"].tolist() == [False, False, False, True, False, False, False]


def test_reused_blocks_never_change_arrays_a_caller_keeps() -> None:
    """`episode_metrics` arrays built in reused blocks (`InfoBlocks`) equal fresh ones, and
    arrays a caller keeps (one array, or the whole dict) keep their values while later steps
    build theirs; blocks nobody holds are taken again."""
    from opends_gym.vector.episode_rows import InfoBlocks, metrics_arrays, table_of_rows

    rng = np.random.default_rng(7)
    blocks, kept, want = InfoBlocks(), [], []
    for step in range(40):
        envs = sorted(rng.choice(50, size=int(rng.integers(1, 6)), replace=False).tolist())
        rows = [{"duration_s": float(rng.random()), **({"sign00_latency_s": 1.0 + step} if e % 2 else {}), "lane_changes": float(e)}
                for e in envs]  # fmt: skip
        table = [(envs, table_of_rows(rows))]
        got, fresh = metrics_arrays(table, 50, blocks), metrics_arrays(table, 50)
        assert list(got) == list(fresh)
        for key, array in fresh.items():
            assert got[key].dtype == array.dtype
            np.testing.assert_array_equal(got[key], array, err_msg=key)
        if step % 3 == 0:  # keep the whole dict, or a single array of it
            kept.append(got)
            want.append({k: v.copy() for k, v in got.items()})
        elif step % 3 == 1:
            kept.append({"duration_s": got["duration_s"]})
            want.append({"duration_s": got["duration_s"].copy()})
    for have, expect in zip(kept, want, strict=True):
        for key, array in expect.items():
            np.testing.assert_array_equal(have[key], array, err_msg=key)
    pooled = {id(entry[0]) for entry in blocks._pool}
    kept.clear()
    again = metrics_arrays([([3], table_of_rows([{"duration_s": 1.0}]))], 50, blocks)
    assert again["duration_s"].base is not None and id(again["duration_s"].base) in pooled  # (a free block was taken again)
    assert again["duration_s"].tolist() == [0.0] * 3 + [1.0] + [0.0] * 46
