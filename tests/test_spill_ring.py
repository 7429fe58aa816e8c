"""The bounded trace ring (`SpillRing`) reads every episode as the unbounded `TraceRing` does, in a fixed number of blocks."""

from __future__ import annotations

import numpy as np
import pytest

from opends_gym.vector.spill_ring import SpillRing
from opends_gym.vector.trace import TraceRing


@pytest.mark.parametrize("grouped", [False, True])
def test_spill_ring_reads_the_rows_trace_ring_reads(grouped: bool) -> None:
    """5 envs, 3,000 steps: env 0 never resets (its episode spans 12 blocks), env 1 stops
    stepping for a long while, the others reset at random; episodes are read while running."""
    n, cols = 5, ("x_m", "z_m", "lon_dev")
    rng = np.random.default_rng(4)
    plain, bounded = TraceRing(n, cols, 4000, grouped), SpillRing(n, cols, 4000, grouped, max_blocks=3)
    first = {c: rng.standard_normal(n) for c in cols}
    for ring in (plain, bounded):
        ring.reset_rows(np.arange(n), first)
    for step in range(3000):
        live = rng.random(n) < 0.97
        live[0], live[1] = True, live[1] and not 600 <= step < 1500
        values = {c: rng.standard_normal(n) for c in cols}
        for ring in (plain, bounded):
            ring.write(values, live)
        ending = np.flatnonzero(rng.random(n) < 0.004)
        ending = ending[ending > 0]
        if step % 97 == 0 or ending.size:
            es = list(range(n))
            (s1, d1), (s2, d2) = plain.gather(es), bounded.gather(es)
            assert np.array_equal(s1, s2) and np.array_equal(d1, d2), step
            c1, c2 = plain.columns_of(es), bounded.columns_of(es)
            assert all(np.array_equal(c1[e], c2[e]) for e in es)
            assert np.array_equal(plain.column(0, "z_m"), bounded.column(0, "z_m"))
        if ending.size:
            reset = {c: rng.standard_normal(n)[ending] for c in cols}
            for ring in (plain, bounded):
                ring.reset_rows(ending, reset)
    assert len(bounded.blocks) + len(bounded._spare) <= 3 < len(plain.blocks)
    assert bounded.steps[0] == 3000 and bounded.spilled[0] > 2000
