"""Compiled per-physics-step loops of a native batch: trigger contacts, reaction timers, lanes.

Why: these run every physics step for every env; as numpy they were dozens of array
operations each (and a numpy call costs microseconds whatever its size). Each function here
is one loop over the envs with the single env's arithmetic (`sim.geometry2d.boxes_overlap`,
`sim.jit.py_hypot` where the single env calls `math.hypot`), so the results stay the single
env's. The kernels release the GIL, so shards stepped in threads run them in parallel.
Units: metres, seconds, m/s; `t` is each env's simulation time.
"""

from __future__ import annotations

import math

import numpy as np

from ..sim.controls import STEERING_WHEEL_MAX_DEG
from ..sim.geometry2d import boxes_overlap
from ..sim.jit import inline, kernel, py_hypot
from ..sim.road import LANE_MARGIN_M
from ..sim.triggers.reactions import EPS

# columns of a timer spec table row (`TimerBatch.table`)
T_KIND, T_TIME_LIMIT, T_DISTANCE_LIMIT, T_TARGET_LANE, T_MIN_STEERING, T_ALLOW_BRAKE, T_HOLD = range(7)
T_TARGET_SPEED, T_MUST_PRESS, T_ALLOW_LANE_CHANGE = 7, 8, 9
N_TABLE = 10
LANE = 0  # (timers.LANE)
FAIL, MISS, SUCCESS = 1, 2, 3


@kernel
def touch_triggers(x: np.ndarray, z: np.ndarray, yaw: np.ndarray, shift: float, rows: np.ndarray, hx: float, hz: float,
                   cz: np.ndarray, cx: np.ndarray, reach: np.ndarray, table: np.ndarray, vol_triggers: np.ndarray, t: np.ndarray,
                   locks: np.ndarray, out: np.ndarray) -> int:  # fmt: skip
    """The trigger volume each car box (reference point x, z, heading yaw, centred `shift`
    ahead, half sizes hx, hz) of the envs `rows` overlaps and that has a trigger not locked
    at time t (`out`, -1: none); the number of such envs. Volumes are sorted by cz and lie
    far apart, so the nearest along z is the only candidate; `vol_triggers` lists each
    volume's triggers (-1 padded)."""
    count = 0
    nv = len(cz)
    for e in range(len(x)):
        out[e] = -1
        if not rows[e] or nv == 0:
            continue
        a = yaw[e]
        bx, bz = x[e] - shift * math.sin(a), z[e] - shift * math.cos(a)
        k = np.searchsorted(cz, bz)
        lo = k - 1 if k > 0 else 0
        hi = k if k < nv - 1 else nv - 1
        j = lo if abs(cz[lo] - bz) <= abs(cz[hi] - bz) else hi
        if not (abs(cz[j] - bz) < reach[j] and abs(cx[j] - bx) < reach[j] + 50.0):
            continue
        if not boxes_overlap(bx, bz, a, hx, hz, table[j, 0], table[j, 1], table[j, 2], table[j, 3], table[j, 4]):
            continue
        for i in vol_triggers[j]:
            if i >= 0 and t[e] >= locks[e, i] - 1e-9:
                out[e] = j
                count += 1
                break
    return count


@inline
def lane_at(x: float, bands: np.ndarray) -> int:
    """`RoadModel.lane_id_at` as an index into the road's lanes (-1: none)."""
    for i in range(bands.shape[0]):
        if bands[i, 0] + LANE_MARGIN_M <= x <= bands[i, 1] - LANE_MARGIN_M:
            return i
    return -1


@kernel
def update_timers(active: np.ndarray, armed: np.ndarray, spec: np.ndarray, start_t: np.ndarray, start_x: np.ndarray, start_z: np.ndarray,
                  peak: np.ndarray, hold_since: np.ndarray, braked: np.ndarray, start_lane: np.ndarray, table: np.ndarray,
                  bands: np.ndarray, rows: np.ndarray, t: np.ndarray, x: np.ndarray, z: np.ndarray, u: np.ndarray, steer: np.ndarray,
                  brake: np.ndarray, done: np.ndarray) -> int:  # fmt: skip
    """`ReactionCenter.update` for the running timers of the envs `rows`: steering peak, brake,
    lane and speed checks, hold times and limits. A timer that ends is flagged in `done`
    (FAIL, MISS, SUCCESS) for Python to score; returns how many ended."""
    count = 0
    for e in range(len(active)):
        done[e] = 0
        if not (active[e] and rows[e]):
            continue
        k = spec[e]
        lane_kind = table[k, T_KIND] == LANE
        tl, dl = table[k, T_TIME_LIMIT], table[k, T_DISTANCE_LIMIT]
        limit = (tl > 0.0 and t[e] - start_t[e] > tl + EPS) or (dl > 0.0 and py_hypot(x[e] - start_x[e], z[e] - start_z[e]) > dl)
        arm = armed[e]
        if not arm and limit:
            active[e] = False  # an unarmed timer only expires
        if lane_kind:
            p = abs(steer[e]) * STEERING_WHEEL_MAX_DEG
            peak[e] = peak[e] if peak[e] >= p else p
        else:
            braked[e] = braked[e] or brake[e] > 0.0
        lane = lane_at(x[e], bands)
        if lane_kind:
            fail = table[k, T_ALLOW_BRAKE] == 0.0 and brake[e] > 0.0
        else:
            fail = table[k, T_ALLOW_LANE_CHANGE] == 0.0 and lane >= 0 and start_lane[e] >= 0 and lane != start_lane[e]
        fail = fail and arm
        miss = arm and not fail and limit
        rest = arm and not fail and not miss
        if lane_kind:
            ok = lane == table[k, T_TARGET_LANE] and peak[e] >= table[k, T_MIN_STEERING] - EPS
        else:
            ok = u[e] <= table[k, T_TARGET_SPEED] + EPS and (braked[e] or table[k, T_MUST_PRESS] == 0.0)
        hold = hold_since[e]
        if rest and ok and math.isnan(hold):
            hold = t[e]
        if rest and not ok:
            hold = math.nan
        hold_since[e] = hold
        success = rest and ok and t[e] - hold >= table[k, T_HOLD] - EPS
        if fail or miss or success:
            done[e] = FAIL if fail else MISS if miss else SUCCESS
            count += 1
    return count


@inline
def lane_of(lateral: float, centres: np.ndarray, half_width: float) -> tuple[int, int]:
    """(lane index, -1 off the lanes; index of the lane whose centre the offset is measured
    from: that lane, or off the lanes the nearest one, the first of equals)."""
    ln, ref, best = -1, 0, math.inf
    for i in range(len(centres)):
        gap = abs(lateral - centres[i])
        if ln < 0 and gap <= half_width:
            ln = i
        if gap < best:
            ref, best = i, gap
    return ln, (ln if ln >= 0 else ref)


@kernel
def record_lanes(x: np.ndarray, z: np.ndarray, rows: np.ndarray, first: bool, sign: float, centres: np.ndarray, half_width: float,
                 keep_m: float, lat: np.ndarray, lane: np.ndarray, offset: np.ndarray, n: np.ndarray, mean: np.ndarray, m2: np.ndarray,
                 distance: bool, prev_x: np.ndarray, prev_z: np.ndarray, dist: np.ndarray, area: np.ndarray) -> None:  # fmt: skip
    """`OpenDSEnv._record_row`'s lane measures for the envs `rows`: lateral position, lane
    (-1 off the lanes) and offset from the lane's centre (or the nearest lane's), the running
    SDLP terms (Welford, samples within `keep_m` of the centre) and, with `distance`, the
    distance driven and the area between the path and the lane centres (mean deviation)."""
    for e in range(len(x)):
        if not rows[e]:
            continue
        la = -sign * x[e]
        ln, ref = lane_of(la, centres, half_width)
        off = la - centres[ref]
        if distance and not first:
            ds = py_hypot(x[e] - prev_x[e], z[e] - prev_z[e])
            dist[e] = dist[e] + ds
            area[e] = area[e] + 0.5 * (abs(offset[e]) + abs(off)) * ds
        if abs(off) < keep_m:
            count = n[e] + 1.0
            d = off - mean[e]
            mean[e] = mean[e] + d / count
            m2[e] = m2[e] + d * (off - mean[e])
            n[e] = count
        lat[e], lane[e], offset[e] = la, ln, off
        if distance:
            prev_x[e], prev_z[e] = x[e], z[e]
