"""What the ego car asks of traffic every physics step, as compiled kernels.

Why: the lead vehicle (ACC, headway, TTC) and the contact test against traffic run every
physics step; as numpy they cost ~10 us each in fixed overhead whatever the number of
cars. Each is one loop over the objects here, with the same arithmetic as before.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import kernel, python_buffers
from ..geometry2d import boxes_overlap


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


@python_buffers
@kernel
def nearest_slots(pos: np.ndarray, yaw: np.ndarray, speed: np.ndarray, enabled: np.ndarray, brake_light: np.ndarray,
                  turn_signal: np.ndarray, group: int, ego: np.ndarray, k: int, out: np.ndarray, col: int) -> None:  # fmt: skip
    """The kinematics observation's K nearest-vehicle slots of each world (`group` objects
    each; `ego` rows x, z, yaw, speed per world) into out[world, col:col + 6K]: present,
    ahead m, left m (ego frame), speed along the ego's heading relative to it m/s, brake
    light, turn signal. Nearest first (ties: the lower index); empty slots are zeros. (Each
    world's distances are taken once, then its K nearest picked from them.)"""
    taken = np.zeros(group, dtype=np.bool_)
    dist = np.empty(group)
    for g in range(ego.shape[1]):
        x, z, eyaw, u = ego[0, g], ego[1, g], ego[2, g], ego[3, g]
        fx, fz = -math.sin(eyaw), -math.cos(eyaw)
        lx, lz = -math.cos(eyaw), math.sin(eyaw)
        lo = g * group
        for j in range(group):
            taken[j] = not enabled[lo + j]
            dist[j] = math.hypot(pos[lo + j, 0] - x, pos[lo + j, 2] - z) if enabled[lo + j] else math.inf
        for slot in range(k):
            best, best_d = -1, math.inf
            for j in range(group):
                if not taken[j] and dist[j] < best_d:
                    best, best_d = j, dist[j]
            base = col + 6 * slot
            if best < 0:  # (a disabled car ends the list)
                for c in range(base, col + 6 * k):
                    out[g, c] = 0.0
                break
            taken[best] = True
            j = lo + best
            dx, dz = pos[j, 0] - x, pos[j, 2] - z
            vyaw = yaw[j]
            v_along = speed[j] * (-math.sin(vyaw) * fx - math.cos(vyaw) * fz)
            out[g, base], out[g, base + 1], out[g, base + 2] = 1.0, dx * fx + dz * fz, dx * lx + dz * lz
            out[g, base + 3], out[g, base + 4], out[g, base + 5] = v_along - u, 1.0 if brake_light[j] else 0.0, float(turn_signal[j])
