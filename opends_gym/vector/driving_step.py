"""The traffic step of a native DrivingTask batch: each world's `motion.step_objects`, worlds in parallel.

Why: `sim.traffic.TrafficManager.step` moves one world's cars with `step_objects` (carrots,
the network legs that need no Python, driving) unless an object needs Python (a wait that is
over, a leg end with a random choice, a jump or an end point). Here every env's world runs
that same kernel on its own slice of the flat state (so each world resamples its carrots only
when one of *its* carrots moved on, as its single env does), chunks of worlds on numba's
threads. A world whose step stopped for Python is marked (`codes`) and finished in Python as
`TrafficManager._step_with_events` does.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ..jit import kernel, parallel_kernel
from ..sim.traffic.motion import NOTHING_LIVE, step_objects
from .kernels import chunk_count


@kernel
def _worlds_range(lo: int, hi: int, f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray,
                  light_xz: np.ndarray, ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray,
                  t: np.ndarray, ego: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray,
                  brake_light: np.ndarray, turn_signal: np.ndarray, net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray,
                  codes: np.ndarray) -> int:  # fmt: skip
    """`step_objects` for the worlds lo..hi-1 that are `live` (each `c` cars); codes[w]: 0 done,
    NOTHING_LIVE, or the code of a step that stopped for Python. Returns how many stopped."""
    left = 0
    for w in range(lo, hi):
        a, z = w * c, (w + 1) * c
        if not live[w]:
            codes[w] = NOTHING_LIVE
            for k in range(a, z):
                flags[k] = 0
            continue
        code, _ = step_objects(f[:, a:z], i[:, a:z], b[:, a:z], pos[a:z], end_xz[a:z], light_xz[a:z], ext_cmd[a:z], sp[:, a:z], pf, pp,
                               pi, t[w : w + 1], ego[:, w : w + 1], dt, work[:, a:z], flags[a:z], stop_mask, brake_light[a:z],
                               turn_signal[a:z], net, quiet[a:z])  # fmt: skip
        codes[w] = code
        if code != 0 and code != NOTHING_LIVE:
            left += 1
    return left


@parallel_kernel
def step_worlds(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t: np.ndarray, ego: np.ndarray,
                dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray,
                net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray, codes: np.ndarray) -> int:  # fmt: skip
    """`_worlds_range` over all worlds, chunks on numba's threads."""
    n = len(live)
    chunks = chunk_count(n)
    left = np.zeros(chunks, dtype=np.int64)
    for k in prange(chunks):
        left[k] = _worlds_range(k * n // chunks, (k + 1) * n // chunks, f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t,
                                ego, dt, work, flags, stop_mask, brake_light, turn_signal, net, quiet, c, live, codes)  # fmt: skip
    return int(left.sum())
