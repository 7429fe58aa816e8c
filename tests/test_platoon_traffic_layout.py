"""The brake and platoon batches keep their traffic car-major (`FlatTraffic(car_major=True)`):
the leg events Python handles for one world (`platoon_pass.traffic_events`) must step that
world's cars exactly as on the row-major state, and leave the other worlds alone."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.sim.traffic.motion import WAITS_OVER
from opends_gym.vector.platoon_pass import traffic_events
from opends_gym.vector.traffic import FlatTraffic


def _state(tr: FlatTraffic) -> list[np.ndarray]:
    st = tr.st
    return [st.f, st.i, st.b, st.pos, tr.work, tr.flags]


def test_traffic_events_on_car_major_state_step_one_world_as_row_major() -> None:
    env = gym.make("OpenDS/ThreeVehiclePlatoon-v0")
    env.reset(seed=0)
    tm = env.unwrapped.world.traffic  # type: ignore[attr-defined]
    flats = [FlatTraffic(tm, 3, 4.5, (0.9, 2.25), car_major=major) for major in (False, True)]
    assert flats[1].st.f.flags.f_contiguous and not flats[1].st.f.flags.c_contiguous
    t, ego3, dt = np.full(3, 2.0), np.zeros((3, 3)), 1.0 / 60.0
    ego3[0] = 1e6  # (the ego cars far away: no car waits for one)
    before = [a.copy() for a in _state(flats[1])]
    for tr in flats:
        for _ in range(30):  # the waits-over path: advance_carrots, then drive, on world 1 only
            traffic_events(tr, 1, WAITS_OVER, dt, t, ego3)
            t[1] += dt
            ego3[0, 1] = 1e6
    row_major, car_major = (_state(tr) for tr in flats)
    for a, b in zip(row_major, car_major, strict=True):
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    c = flats[1].c
    pos = flats[1].st.pos
    assert not np.array_equal(pos[c : 2 * c], before[3][c : 2 * c])  # world 1's cars moved
    assert np.array_equal(pos[:c], before[3][:c]) and np.array_equal(pos[2 * c :], before[3][2 * c :])
    env.close()
