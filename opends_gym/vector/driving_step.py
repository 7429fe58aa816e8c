"""The traffic step of a native DrivingTask batch: each world's `motion.step_objects`, worlds in parallel.

Why: `sim.traffic.TrafficManager.step` moves one world's cars with `step_objects` (carrots,
the network legs that need no Python, driving) unless an object needs Python (a wait that is
over, a leg end with a random choice, a jump or an end point). Here every env's world runs
that same kernel on its own slice of the flat state (so each world resamples its carrots only
when one of *its* carrots moved on, as its single env does), chunks of worlds on numba's
threads. A world whose step stopped for Python is marked (`codes`) and finished in Python as
`TrafficManager._step_with_events` does. `contacts` is `World._contacts` for all envs in one pass.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..jit import borrowing_kernel, kernel, parallel_kernel
from ..sim.geometry2d import boxes_overlap
from ..sim.traffic.motion import NOTHING_LIVE, step_rows
from .kernels import chunk_count


@borrowing_kernel
def _worlds_range(lo: int, hi: int, f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray,
                  light_xz: np.ndarray, ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray,
                  t: np.ndarray, ego: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray,
                  brake_light: np.ndarray, turn_signal: np.ndarray, net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray,
                  codes: np.ndarray, rows: np.ndarray) -> int:  # fmt: skip
    """`step_objects` for the worlds lo..hi-1 that are `live` (each `c` cars; `motion.step_rows`
    on the whole arrays); codes[w]: 0 done, NOTHING_LIVE, or the code of a step that stopped for
    Python. Returns how many stopped. `rows`: all True, one per car (compiled without
    reference counting, `jit.borrowing_kernel`: it allocates nothing)."""
    left = 0
    for w in range(lo, hi):
        a, z = w * c, (w + 1) * c
        if not live[w]:
            codes[w] = NOTHING_LIVE
            for k in range(a, z):
                flags[k] = 0
            continue
        code, _ = step_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego, dt, work, flags, stop_mask, brake_light,
                            turn_signal, net, quiet, c, rows, a, z)  # fmt: skip
        codes[w] = code
        if code != 0 and code != NOTHING_LIVE:
            left += 1
    return left


@parallel_kernel
def step_worlds(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t: np.ndarray, ego: np.ndarray,
                dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray,
                net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray, codes: np.ndarray, rows: np.ndarray) -> int:  # fmt: skip
    """`_worlds_range` over all worlds, chunks on numba's threads."""
    n = len(live)
    chunks = chunk_count(n)
    left = np.zeros(chunks, dtype=np.int64)
    for k in prange(chunks):
        left[k] = _worlds_range(k * n // chunks, (k + 1) * n // chunks, f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t,
                                ego, dt, work, flags, stop_mask, brake_light, turn_signal, net, quiet, c, live, codes, rows)  # fmt: skip
    return int(left.sum())


@kernel
def contacts(live: np.ndarray, cx: np.ndarray, cz: np.ndarray, yaw: np.ndarray, ey: np.ndarray, hx: float, hz: float, pos: np.ndarray,
             car_yaw: np.ndarray, enabled: np.ndarray, half: np.ndarray, reach: np.ndarray, reach_y: float, c: int, hitting: np.ndarray,
             obs: np.ndarray, obs_hitting: np.ndarray, new: np.ndarray, stop: np.ndarray) -> None:  # fmt: skip
    """`World._contacts` of the ego boxes (centre cx, cz, heading yaw, half sizes hx, hz; the
    car at height ey) of the envs `live`: the traffic cars they overlap (`queries.touching`,
    within `reach_y` in height) and the static obstacles (rows of `obs`: centre x, z, heading,
    half sizes). new[e]: the contacts that begin now (a collision each); stop[e]: the box
    touches an obstacle (the car stops)."""
    for e in range(len(live)):
        new[e] = 0
        stop[e] = False
        if not live[e]:
            continue
        for j in range(c):
            r = e * c + j
            hit = False
            if enabled[r]:
                dx, dz = pos[r, 0] - cx[e], pos[r, 2] - cz[e]
                if math.sqrt(dx * dx + dz * dz) < reach[r] and boxes_overlap(
                    cx[e], cz[e], yaw[e], hx, hz, pos[r, 0], pos[r, 2], car_yaw[r], half[r, 0], half[r, 1]
                ):
                    hit = abs(pos[r, 1] - ey[e]) < reach_y
            if hit and not hitting[r]:
                new[e] += 1
            hitting[r] = hit
        for j in range(obs.shape[0]):
            hit = boxes_overlap(cx[e], cz[e], yaw[e], hx, hz, obs[j, 0], obs[j, 1], obs[j, 2], obs[j, 3], obs[j, 4])
            if hit:
                stop[e] = True
                if not obs_hitting[e, j]:
                    new[e] += 1
            obs_hitting[e, j] = hit
