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
