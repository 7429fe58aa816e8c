"""The brake and platoon batches test their trigger volumes only when the answer may have
changed (`platoon_pass.gated_contact`): while no volume is within reach, and while the one
within reach has every trigger locked (a car standing in it after it fired). Over drives
that cross, stop in and creep through volumes, with triggers that re-arm and fire again,
its answer must be, at every physics step, that of searching every time
(`nearest_volume` then `volume_fires`)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from opends_gym import jit
from opends_gym.vector import kernels, platoon_pass

CAR_HALF = (0.9, 2.3)  # half width, half length of the trigger box (m)
LOCK_S = 2.0  # a fired trigger is locked this long (OpenDS's 2 s), plus its pause
DT = 1.0 / 60.0


def _volumes(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Six thin gates across the road, spaced along -z as the batch requires (`TriggerBatch`),
    each with one or two of seven triggers (the pauses of those triggers)."""
    car_r = math.hypot(*CAR_HALF)
    cz = -np.cumsum(rng.uniform(30.0, 60.0, 6))[::-1]  # sorted by z, as `vols` is
    rows, owners = [], []
    for k, z in enumerate(cz):
        hx, hz, yaw = 4.75, rng.choice([0.25, 1.5]), rng.uniform(-0.05, 0.05)
        cx = rng.uniform(-1.0, 1.0)
        rows.append((z, cx, math.hypot(hx, hz) + car_r + 1.0, yaw, hx, hz, math.sin(yaw), math.cos(yaw), car_r))
        owners.append([k, 6] if k % 3 == 0 else [k, -1])  # trigger 6 sits in two volumes
    vols = np.array(rows).reshape(-1, kernels.N_VOL)
    return vols, np.array(owners, dtype=np.int64), rng.choice([0.0, 0.5, 3.0], 7)


def _drive(rng: np.random.Generator, steps: int, gates_z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box's centre and heading: along -z at changing speeds, weaving a little, stopping now
    and then for a few seconds, and in most gates it enters (for 1-7 s: long enough for some
    triggers to re-arm)."""
    x, z, speed, stop_left = 0.0, 5.0, 10.0, 0
    entered: set[int] = set()
    xs, zs, yaws = np.empty(steps), np.empty(steps), np.empty(steps)
    for k in range(steps):
        inside = int(np.argmin(np.abs(gates_z - z)))
        if stop_left > 0:
            stop_left -= 1
            v = 0.0
        else:
            if abs(gates_z[inside] - z) < 1.0 and inside not in entered:
                entered.add(inside)
                stop_left = int(rng.uniform(1.0, 7.0) / DT) if rng.random() < 0.7 else 0
            elif rng.random() < 0.002:
                stop_left = int(rng.uniform(1.0, 7.0) / DT)
            speed = float(np.clip(speed + rng.normal(0.0, 0.3), 0.3, 25.0))
            v = speed
        yaw = 0.03 * math.sin(k / 90.0)
        x, z = x - v * DT * math.sin(yaw), z - v * DT * math.cos(yaw)
        xs[k], zs[k], yaws[k] = x, z, yaw
    return xs, zs, yaws


@pytest.mark.parametrize("substeps", [6, 300])  # physics steps per policy step (10 Hz, 0.2 Hz): the gate's memory lasts one
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_gated_contact_answers_as_searching_every_step(seed: int, substeps: int) -> None:
    rng = np.random.default_rng(seed)
    vols, vol_triggers, pause = _volumes(rng)
    xs, zs, yaws = _drive(rng, 60 * 120, vols[:, kernels.V_CZ])
    gate = jit.python_twin(platoon_pass.gated_contact)  # (the kernel's Python form: the same decisions, no compile)
    nearest, fires = jit.python_twin(kernels.nearest_volume), jit.python_twin(kernels.volume_fires)
    locks = np.full((1, 7), -np.inf)
    near_gate, near_search = np.zeros(1, dtype=np.int64), 0
    hx, hz = CAR_HALF
    fired: list[tuple[int, float]] = []
    skipped_locked = 0
    anchor, clear, wake = 0.0, -math.inf, math.inf
    for k in range(len(zs)):
        if k % substeps == 0:
            anchor, clear, wake = 0.0, -math.inf, math.inf
        t = (k + 1) * DT
        j, near_search = nearest(xs[k], zs[k], vols, near_search)
        want = j if j >= 0 and fires(0, j, xs[k], zs[k], yaws[k], hx, hz, vols, vol_triggers, t, locks) else -1
        got, anchor, clear, wake = gate(0, xs[k], zs[k], yaws[k], t, hx, hz, vols, vol_triggers, locks, near_gate, anchor, clear, wake)
        assert got == want, f"seed {seed}, step {k}: gate {got}, search {want}"
        skipped_locked += int(math.isfinite(wake))
        if got >= 0:  # fire: every armed trigger of the volume locks (`TriggerBatch.fire`)
            fired.append((got, t))
            for i in vol_triggers[got]:
                if i >= 0 and t >= locks[0, i] - 1e-9:
                    locks[0, i] = t + LOCK_S + pause[i]
    again = [b for a, b in itertools.pairwise(fired) if a[0] == b[0]]
    assert len(fired) >= 4 and again and skipped_locked > 100  # crossings, a re-fire while standing in a gate, locked skips
