"""The traffic kernel keeps a car's yaw sine/cosine and each world's neighbour order between
steps only to save work: whatever those rows hold, the traffic moves the same."""

from __future__ import annotations

import numpy as np

from opends_gym.sim.traffic.motion import W_COS, W_ORDER, W_SIN, W_TRIG_OK, W_TRIG_YAW
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import load_task

from .conftest import CORPUS


def test_stale_kept_rows_do_not_change_the_traffic() -> None:
    task = load_task(CORPUS / "opends-cts" / "MotorwayTask")  # 41 cars: its worlds sort their cars for the obstacle search
    worlds = [World(task, WorldConfig(), seed=5) for _ in range(3)]
    for w in worlds:
        w.run(2.0)
    n = len(worlds[0].traffic.ids)
    shuffled, garbage = worlds[1].traffic._work, worlds[2].traffic._work
    shuffled[W_ORDER] = np.random.default_rng(0).permutation(n)  # a permutation, out of order: sorted again
    shuffled[W_TRIG_YAW] += 1.0  # kept for another yaw: taken afresh
    shuffled[W_SIN] = shuffled[W_COS] = 2.0
    garbage[W_ORDER] = 3.0  # not a permutation: started afresh
    garbage[W_TRIG_OK] = 0.0
    garbage[W_SIN] = garbage[W_COS] = 2.0
    for _ in range(240):
        runs = []
        for w in worlds:
            w.step()
            tr = w.traffic
            runs.append(np.concatenate([tr.positions.ravel(), tr.speed, tr.yaw, tr.st.blocked]))
        assert np.array_equal(runs[0], runs[1]) and np.array_equal(runs[0], runs[2])
    assert worlds[0].traffic.st.blocked.any() or worlds[0].traffic.speed.max() > 20.0  # (the cars drove)
