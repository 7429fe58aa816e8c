"""Compiled per-physics-step loops of a native batch: trigger contacts, reaction timers, lanes.

Why: these run every physics step for every env; as numpy they were dozens of array
operations each (and a numpy call costs microseconds whatever its size). Each function here
is one loop over the envs with the single env's arithmetic (`sim.geometry2d.boxes_overlap`,
`jit.py_hypot` where the single env calls `math.hypot`), so the results stay the single
env's. The kernels release the GIL, so shards stepped in threads run them in parallel.
Units: metres, seconds, m/s; `t` is each env's simulation time.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ..jit import inline, kernel, py_hypot
from ..sim.geometry2d import boxes_overlap
from ..sim.road import LANE_MARGIN_M
from ..sim.triggers.reactions import EPS

# columns of a timer spec table row (`TimerBatch.table`)
T_KIND, T_TIME_LIMIT, T_DISTANCE_LIMIT, T_TARGET_LANE, T_MIN_STEERING, T_ALLOW_BRAKE, T_HOLD = range(7)
T_TARGET_SPEED, T_MUST_PRESS, T_ALLOW_LANE_CHANGE = 7, 8, 9
N_TABLE = 10
LANE = 0  # (timers.LANE)
# columns of a trigger volume row (`TriggerBatch.vols`): centre, reach (no contact farther away along z), heading, half sizes,
# the heading's sine and cosine and the car box's half diagonal (`volume_fires`' quick reject)
V_CZ, V_CX, V_REACH, V_YAW, V_HX, V_HZ, V_SIN, V_COS, V_CAR_R = range(9)
N_VOL = 9
# margin of `volume_fires`' quick reject (m): far above the rounding of the separating-axis test's sums (~1e-12 m here)
REJECT_MARGIN_M = 1e-6
FAIL, MISS, SUCCESS = 1, 2, 3
CHUNK_ENVS = 128  # envs per chunk of a parallel step (`chunk_count`)


@inline
def chunk_count(n: int) -> int:
    """Chunks of about CHUNK_ENVS envs that the threads of a parallel step take one at a
    time: small enough that a thread whose core is busy elsewhere holds up little, large
    enough that taking one costs little next to stepping it."""
    c = (n + CHUNK_ENVS - 1) // CHUNK_ENVS
    return c if c > 1 else 1


@intrinsic
def _fetch_add_one(typingctx: Any, counter: Any, index: Any) -> Any:
    """counter[index] += 1 as one atomic operation (LLVM's atomicrmw); returns the old value."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64 and isinstance(index, types.Integer)):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        ary_t = signature.args[0]
        ary = context.make_array(ary_t)(context, builder, args[0])
        i = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = cgutils.get_item_pointer(context, builder, ary_t, ary, [i])
        return builder.atomic_rmw("add", ptr, context.get_constant(types.int64, 1), "monotonic")

    return types.int64(counter, index), codegen


def take_next(counter: np.ndarray, i: int) -> int:
    """counter[i] += 1 for a parallel step's threads at once (an atomic add); returns the
    old value: the next chunk for the thread that asks (threads take chunks one at a time,
    so one that a busy core or a slow chunk holds up takes fewer; numba's workqueue
    threading layer gives each thread a fixed share of a `prange` loop, whatever
    `parallel_chunksize`), or the next free slot of a list the threads fill. As Python (a
    kernel running as Python while it compiles, `opends_gym.jit`) there is one thread."""
    c = int(counter[i])
    counter[i] = c + 1
    return c


@overload(take_next, inline="always")
def _take_next_compiled(counter: Any, i: Any) -> Any:
    """`take_next` in compiled kernels: the atomic add."""

    def atomic(counter: Any, i: Any) -> Any:  # (the same parameters as the typing function: numba compares them)
        return _fetch_add_one(counter, i)  # type: ignore[call-arg]  # (typingctx: numba passes it)

    return atomic


@kernel
def touch_triggers(x: np.ndarray, z: np.ndarray, yaw: np.ndarray, shift: float, rows: np.ndarray, hx: float, hz: float,
                   vols: np.ndarray, vol_triggers: np.ndarray, t: np.ndarray, locks: np.ndarray, near: np.ndarray,
                   out: np.ndarray) -> int:  # fmt: skip
    """The trigger volume each car box (reference point x, z, heading yaw, centred `shift`
    ahead, half sizes hx, hz) of the envs `rows` overlaps and that has a trigger not locked
    at time t (`out`, -1: none); the number of such envs. `near` keeps each env's place in
    the volume table (`nearest_volume`)."""
    count = 0
    for e in range(len(x)):
        out[e] = -1
        if rows[e]:
            bx, bz = box_centre(x[e], z[e], yaw[e], shift)
            j, near[e] = nearest_volume(bx, bz, vols, near[e])
            if j >= 0 and volume_fires(e, j, bx, bz, yaw[e], hx, hz, vols, vol_triggers, t[e], locks):
                out[e] = j
                count += 1
    return count


@inline
def box_centre(x: float, z: float, yaw: float, shift: float) -> tuple[float, float]:
    """The centre of a car box whose reference point is (x, z), centred `shift` ahead."""
    return x - shift * math.sin(yaw), z - shift * math.cos(yaw)


@inline
def nearest_volume(bx: float, bz: float, vols: np.ndarray, hint: int) -> tuple[int, int]:
    """The trigger volume (row of `vols`, sorted by V_CZ) a box centred at (bx, bz) may touch
    (-1: none within reach), and the first row with cz >= bz (np.searchsorted's), found by
    walking from `hint` (that row at the last call: a car moves little between calls).
    Volumes lie far apart, so the nearest along z is the only candidate."""
    nv = vols.shape[0]
    if nv == 0:
        return -1, 0
    lo = hint if 0 <= hint <= nv else 0
    while lo > 0 and vols[lo - 1, V_CZ] >= bz:
        lo -= 1
    while lo < nv and vols[lo, V_CZ] < bz:
        lo += 1
    a = lo - 1 if lo > 0 else 0
    b = lo if lo < nv - 1 else nv - 1
    j = a if abs(vols[a, V_CZ] - bz) <= abs(vols[b, V_CZ] - bz) else b
    reach = vols[j, V_REACH]
    return (j if abs(vols[j, V_CZ] - bz) < reach and abs(vols[j, V_CX] - bx) < reach + 50.0 else -1), lo


@inline
def volume_fires(e: int, j: int, bx: float, bz: float, yaw: float, hx: float, hz: float, vols: np.ndarray, vol_triggers: np.ndarray,
                 t: float, locks: np.ndarray) -> bool:  # fmt: skip
    """Does env e's car box (centre bx, bz, heading yaw, half sizes hx, hz) overlap volume j,
    which has a trigger not locked at time t? (`vol_triggers` lists each volume's triggers,
    -1 padded.) Called only near a volume: it takes arrays, which an inlined call pays for.

    Before the separating-axis test (two sines and cosines, four axes), a quick reject: the
    car box lies within its half diagonal of its centre, so a centre farther than that plus
    the volume's half size from the volume's centre along one of the volume's axes is
    separated on that axis, which `boxes_overlap` tests too; with REJECT_MARGIN_M to spare,
    both decide alike (its sums round by ~1e-12 m at these sizes), and the car usually
    passes a thin sign gate's box within reach for a second or more before it touches it.
    The locks are tested first: the answer is the same, and a car inside a volume (its
    triggers locked after they fired) skips the geometry."""
    if not t >= armed_from(e, j, vol_triggers, locks):  # (first: with every trigger locked, as while the car stays in a volume)
        return False
    return volume_touches(j, bx, bz, yaw, hx, hz, vols)


@inline
def armed_from(e: int, j: int, vol_triggers: np.ndarray, locks: np.ndarray) -> float:
    """The time from which a trigger of volume j is armed for env e: the least of its
    triggers' `locks[e, i] - 1e-9` (a trigger is armed at t >= that); inf without one."""
    armed = math.inf
    for q in range(vol_triggers.shape[1]):  # (element by element: a kernel run as Python may index a memoryview, `jit.python_buffers`)
        i = vol_triggers[j, q]
        if i >= 0:
            at = locks[e, i] - 1e-9
            armed = at if at < armed else armed
    return armed


@inline
def volume_touches(j: int, bx: float, bz: float, yaw: float, hx: float, hz: float, vols: np.ndarray) -> bool:
    """Does a car box (centre bx, bz, heading yaw, half sizes hx, hz) overlap volume j? The
    quick reject of `volume_fires`' docstring, then `boxes_overlap`."""
    dx, dz = vols[j, V_CX] - bx, vols[j, V_CZ] - bz
    sb, cb, car_r = vols[j, V_SIN], vols[j, V_COS], vols[j, V_CAR_R]
    if abs(dx * sb + dz * cb) > vols[j, V_HZ] + car_r + REJECT_MARGIN_M or abs(dx * cb - dz * sb) > vols[j, V_HX] + car_r + REJECT_MARGIN_M:
        return False
    return boxes_overlap(bx, bz, yaw, hx, hz, vols[j, V_CX], vols[j, V_CZ], vols[j, V_YAW], vols[j, V_HX], vols[j, V_HZ])


@inline
def lane_at(x: float, bands: np.ndarray, margin: float) -> int:
    """`RoadModel.lane_id_at(x, margin)` as an index into the road's lanes (-1: none)."""
    for i in range(bands.shape[0]):
        if bands[i, 0] + margin <= x <= bands[i, 1] - margin:
            return i
    return -1


@kernel
def update_timers(active: np.ndarray, spec: np.ndarray, start_t: np.ndarray, start_x: np.ndarray, start_z: np.ndarray, tlim: np.ndarray,
                  dlim: np.ndarray, peak: np.ndarray, hold_since: np.ndarray, braked: np.ndarray, start_lane: np.ndarray, table: np.ndarray,
                  bands: np.ndarray, rows: np.ndarray, t: np.ndarray, x: np.ndarray, z: np.ndarray, u: np.ndarray, steer: np.ndarray,
                  brake: np.ndarray, done: np.ndarray, done_t: np.ndarray) -> int:  # fmt: skip
    """`timer_step` for the running trials of the envs `rows`. A trial that ends is flagged
    in `done` (FAIL, MISS, SUCCESS; 0 otherwise) at time `done_t` for Python to score;
    returns how many ended."""
    count = 0
    for e in range(len(active)):
        done[e] = 0
        if active[e] and rows[e]:
            how, peak[e], braked[e], hold_since[e] = timer_step(
                table, bands, spec[e], start_t[e], start_x[e], start_z[e], tlim[e], dlim[e], peak[e], hold_since[e], braked[e],
                start_lane[e], t[e], x[e], z[e], u[e], steer[e], brake[e],
            )  # fmt: skip
            if how:
                active[e] = False
                done[e], done_t[e] = how, t[e]
                count += 1
    return count


@inline
def timer_step(table: np.ndarray, bands: np.ndarray, k: int, start_t: float, start_x: float, start_z: float, tlim: float, dlim: float,
               peak: float, hold_since: float, braked: bool, start_lane: int, t: float, x: float, z: float, u: float, steer: float,
               brake: float) -> tuple[int, float, bool, float]:  # fmt: skip
    """LaneChangeReactionTimer.update / BrakeReactionTimer.update for one running trial of
    spec row k (`LaneChangeTimer.update`, `BrakeTimer.update`): steering peak or brake
    flag, then the limits, the forbidden action, the hold clock (NaN: not set). Returns
    (how it ended: FAIL, MISS, SUCCESS or 0; peak, braked, hold_since)."""
    lane_kind = table[k, T_KIND] == LANE
    if lane_kind:
        p = abs(steer)
        peak = peak if peak >= p else p
    else:
        braked = braked or brake > 0.0
    if (tlim > 0.0 and t - start_t > tlim + EPS) or (dlim > 0.0 and py_hypot(x - start_x, z - start_z) > dlim):
        return MISS, peak, braked, hold_since
    if lane_kind:
        fail = table[k, T_ALLOW_BRAKE] == 0.0 and brake > 0.0
    else:  # hasChangedLanes on the raw band: "in no lane" (-1) is another lane too
        fail = table[k, T_ALLOW_LANE_CHANGE] == 0.0 and lane_at(x, bands, 0.0) != start_lane
    if fail:
        return FAIL, peak, braked, hold_since
    if lane_kind:
        held = lane_at(x, bands, LANE_MARGIN_M) == table[k, T_TARGET_LANE]
    else:
        held = u <= table[k, T_TARGET_SPEED] + EPS
    if not held:
        return 0, peak, braked, math.nan
    if math.isnan(hold_since):
        hold_since = t
    if t - hold_since >= table[k, T_HOLD] - EPS:
        ok = peak >= table[k, T_MIN_STEERING] - EPS if lane_kind else braked or table[k, T_MUST_PRESS] == 0.0
        if ok:
            return SUCCESS, peak, braked, hold_since
    return 0, peak, braked, hold_since


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
    """`lane_measures` for the envs `rows`, in place."""
    for e in range(len(x)):
        if rows[e]:
            lat[e], lane[e], offset[e], n[e], mean[e], m2[e], dist[e], area[e] = lane_measures(
                x[e], z[e], first, sign, centres, half_width, keep_m, offset[e], n[e], mean[e], m2[e], distance, prev_x[e], prev_z[e],
                dist[e], area[e],
            )  # fmt: skip
            if distance:
                prev_x[e], prev_z[e] = x[e], z[e]


@inline
def lane_measures(x: float, z: float, first: bool, sign: float, centres: np.ndarray, half_width: float, keep_m: float, offset: float,
                  n: float, mean: float, m2: float, distance: bool, prev_x: float, prev_z: float, dist: float,
                  area: float) -> tuple[float, int, float, float, float, float, float, float]:  # fmt: skip
    """`OpenDSEnv._record_row`'s lane measures at (x, z): lateral position, lane (-1 off the
    lanes) and offset from the lane's centre (or the nearest lane's), the running SDLP terms
    (Welford n, mean, m2 over samples within `keep_m` of the centre) and, with `distance`, the
    distance driven and the area between the path and the lane centres (mean deviation);
    `offset`, prev_x and prev_z are the previous row's."""
    la = -sign * x
    ln, ref = lane_of(la, centres, half_width)
    off = la - centres[ref]
    if distance and not first:
        ds = py_hypot(x - prev_x, z - prev_z)
        dist = dist + ds
        area = area + 0.5 * (abs(offset) + abs(off)) * ds
    if abs(off) < keep_m:
        count = n + 1.0
        d = off - mean
        mean = mean + d / count
        m2 = m2 + d * (off - mean)
        n = count
    return la, ln, off, n, mean, m2, dist, area


@inline
def heading_error(yaw: float, heading: float) -> float:
    """`ObservationType.ego_features`' heading error: yaw - heading wrapped to [-pi, pi)."""
    return (yaw - heading + math.pi) % (2.0 * math.pi) - math.pi


@kernel
def ego_features(out: np.ndarray, u: np.ndarray, yaw: np.ndarray, heading: float, offset: np.ndarray, lat: np.ndarray, lane: np.ndarray,
                 steer: np.ndarray, r: np.ndarray) -> None:  # fmt: skip
    """`ego_features_row` of every env."""
    for e in range(len(u)):
        ego_features_row(out, e, u[e], yaw[e], heading, offset[e], lat[e], lane[e], steer[e], r[e])


@inline
def ego_features_row(out: np.ndarray, e: int, u: float, yaw: float, heading: float, offset: float, lat: float, lane: int, steer: float,
                     r: float) -> None:  # fmt: skip
    """`ObservationType.ego_features` of env e into the first columns of row e of `out`
    (float32): speed, heading error (wrapped to [-pi, pi)), lane offset, lateral position,
    lane, steering, yaw rate."""
    out[e, 0] = u
    out[e, 1] = heading_error(yaw, heading)
    out[e, 2] = offset
    out[e, 3] = lat
    out[e, 4] = lane
    out[e, 5] = steer
    out[e, 6] = r
