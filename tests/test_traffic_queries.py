"""`queries.nearest_slots`: the kinematics observation's nearby-vehicle slots (single env and native batch)."""

from __future__ import annotations

import math

import numpy as np

from opends_gym.sim.traffic.queries import nearest_slots


def test_slots_list_the_nearest_enabled_cars_of_each_world_nearest_first() -> None:
    """Two worlds of four cars: distances from the ego, a tie (the lower index first), a
    disabled car left out, empty slots zero; brake light, turn signal and speed along."""
    pos = np.zeros((8, 3))
    # world 0: ego at the origin facing -Z; car 2 is disabled; cars 1 and 3 tie at 10 m
    pos[:4, 0], pos[:4, 2] = [0.0, 10.0, 1.0, -10.0], [-30.0, 0.0, -1.0, 0.0]
    # world 1: ego at x=100; only car 5 is near, cars 4, 6, 7 are farther in that order
    pos[4:, 0], pos[4:, 2] = [100.0, 103.0, 150.0, 190.0], [-50.0, -4.0, 0.0, 0.0]
    enabled = np.array([True, True, False, True, True, True, True, True])
    yaw = np.zeros(8)
    speed = np.full(8, 20.0)
    brake = np.array([False, True, False, False, True, False, False, False])
    turn = np.array([0, 1, 0, 2, 0, 0, 0, 1], dtype=np.int64)
    ego = np.array([[0.0, 100.0], [0.0, 0.0], [0.0, 0.0], [15.0, 0.0]])  # rows x, z, yaw, speed
    out = np.full((2, 6 * 4), np.nan)
    nearest_slots(pos, yaw, speed, enabled, brake, turn, 4, ego, 4, out, 0)
    w0 = out[0].reshape(4, 6)
    assert w0[:, 0].tolist() == [1.0, 1.0, 1.0, 0.0]  # three enabled cars, then an empty slot
    assert w0[0, 2] == -10.0 and w0[1, 2] == 10.0  # the tie: car 1 (x=10, on the right) before car 3
    assert w0[2, 1] == 30.0 and w0[2, 2] == 0.0  # car 0, 30 m ahead
    assert w0[0, 4:].tolist() == [1.0, 1.0] and w0[1, 4:].tolist() == [0.0, 2.0]
    assert w0[0, 3] == 20.0 - 15.0 and np.all(w0[3] == 0.0)
    w1 = out[1].reshape(4, 6)
    ahead = [-(p[2] - 0.0) for p in pos[[5, 4, 6, 7]]]
    assert w1[:, 0].tolist() == [1.0] * 4 and w1[:, 1].tolist() == ahead
    dists = [math.hypot(p[0] - 100.0, p[2]) for p in pos[[5, 4, 6, 7]]]
    assert dists == sorted(dists)
