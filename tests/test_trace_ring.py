"""The native batch's trace ring: a grouped ring (the LCT's layout) reads back what it was given."""

from __future__ import annotations

import numpy as np

from opends_gym.vector.trace import TraceRing


def _fill(ring: TraceRing, rng: np.random.Generator, steps: int) -> list[np.ndarray]:
    """Write `steps` rows with env 1 restarting its episode on row 300 (so its episode starts
    inside a block, and both episodes cross a block boundary); returns what each env's
    current episode holds (reset row first), column by column."""
    n, cols = ring.n, ring.columns
    first = {c: rng.normal(size=n) for c in cols}
    ring.reset_rows(np.arange(n), first)
    kept = [[[first[c][e]] for c in cols] for e in range(n)]
    for g in range(steps):
        if g == 300:
            again = {c: rng.normal(size=n) for c in cols}
            ring.reset_rows(np.array([1]), {c: v[[1]] for c, v in again.items()})
            kept[1] = [[again[c][1]] for c in cols]
        row = {c: rng.normal(size=n) for c in cols}
        ring.write(row, None)
        for e in range(n):
            for i, c in enumerate(cols):
                kept[e][i].append(row[c][e])
    return [np.array(k) for k in kept]


def test_grouped_ring_reads_back_each_episode_as_written() -> None:
    cols = ("x_m", "z_m", "speed_mps", "steering")
    for grouped in (False, True):
        ring = TraceRing(3, cols, 2000, grouped=grouped)
        expected = _fill(ring, np.random.default_rng(5), 700)
        for parallel in (True, False):  # (chunks of episodes on numba's threads, or one serial pass)
            starts, data = ring.gather([2, 1, 0], parallel)
            for j, e in enumerate([2, 1, 0]):
                np.testing.assert_array_equal(data[:, starts[j] : starts[j + 1]], expected[e])
        by_env = ring.columns_of([0, 1, 2])
        for e in range(3):
            np.testing.assert_array_equal(by_env[e], expected[e])
            np.testing.assert_array_equal(ring.column(e, "z_m"), expected[e][1])
        assert len(expected[1][0]) == 401 and len(expected[0][0]) == 701
