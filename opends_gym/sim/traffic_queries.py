"""What the ego car asks of traffic every physics step, as compiled kernels.

Why: the lead vehicle (ACC, headway, TTC) and the contact test against traffic run every
physics step; as numpy they cost ~10 us each in fixed overhead whatever the number of
cars. Each is one loop over the objects here, with the same arithmetic as before.
"""

from __future__ import annotations

import math

import numpy as np

from .geometry2d import boxes_overlap
from .jit import kernel


@kernel
def nearest_ahead(pos: np.ndarray, enabled: np.ndarray, only: np.ndarray, x: float, z: float, fx: float, fz: float, lx: float,
                  lz: float, half_width_m: float, max_range_m: float) -> tuple[int, float]:  # fmt: skip
    """(index, distance ahead m) of the nearest enabled object (among `only`) ahead of (x, z)
    along the unit vector (fx, fz), within `half_width_m` across (lx, lz) and closer than
    `max_range_m`; (-1, inf) when there is none. Ties go to the lower index."""
    best, best_ahead = -1, math.inf
    for k in range(len(enabled)):
        if not (enabled[k] and only[k]):
            continue
        dx, dz = pos[k, 0] - x, pos[k, 2] - z
        ahead = dx * fx + dz * fz
        side = dx * lx + dz * lz
        if ahead > 0.0 and abs(side) <= half_width_m and ahead < max_range_m and ahead < best_ahead:
            best, best_ahead = k, ahead
    return best, best_ahead


@kernel
def touching(pos: np.ndarray, yaw: np.ndarray, half: np.ndarray, enabled: np.ndarray, reach: np.ndarray, cx: float, cz: float,
             cyaw: float, hx: float, hz: float, out: np.ndarray) -> int:  # fmt: skip
    """Objects whose boxes overlap the box (cx, cz, cyaw, hx, hz): their indices go to `out`,
    the count is returned. `reach` is each object's half diagonal plus the box's."""
    n = 0
    for k in range(len(enabled)):
        if not enabled[k]:
            continue
        dx, dz = pos[k, 0] - cx, pos[k, 2] - cz
        if math.sqrt(dx * dx + dz * dz) < reach[k] and boxes_overlap(
            cx, cz, cyaw, hx, hz, pos[k, 0], pos[k, 2], yaw[k], half[k, 0], half[k, 1]
        ):
            out[n] = k
            n += 1
    return n
