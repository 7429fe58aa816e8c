"""Shared steps of the native batches' identity tests: a batch that checks its actions and
resets in its compiled step against one given the actions already cleaned."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest


def step_both(checked: Any, plain: Any, act: np.ndarray, t: int) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """Step `checked` and `plain` with `act` and assert equal observations, rewards and ends.
    Every 20 steps (at t % 20 == 10) `checked` must first refuse an infinite action, naming
    the env, with nothing stepped; a resetting env's action is NaN for `checked` (it ignores
    it) and 0 for `plain`."""
    n = len(act)
    if t % 20 == 10:
        bad = act.copy()
        bad[n - 7, 1] = np.inf
        with pytest.raises(ValueError, match=f"env {n - 7}: action contains NaN or infinity"):
            checked.step(bad)
    resetting = checked.unwrapped._autoreset.copy()
    if resetting.any():
        act[np.flatnonzero(resetting)[0]] = np.nan  # (an env that resets ignores its action)
    out_a, out_b = checked.step(act), plain.step(np.where(resetting[:, None], 0.0, act).astype(np.float32))
    for x, y in zip(out_a[:4], out_b[:4], strict=True):
        assert np.array_equal(x, y), t
    return out_a, out_b
