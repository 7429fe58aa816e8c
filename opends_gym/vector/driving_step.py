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

from ..jit import borrowing_kernel, inline, kernel, parallel_kernel, python_buffers, python_stand_in, python_twin, whole_batch
from ..sim.geometry2d import boxes_overlap
from ..sim.traffic.motion import NOTHING_LIVE, _sees, step_rows
from ..sim.traffic.state import B_BRAKING, B_ENABLED, F_SPEED, F_YAW, I_BRAKE_PATH, I_OV_BRAKE, I_OV_TURN, I_TURN_PATH
from .kernels import chunk_count


@whole_batch
@python_buffers
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


@whole_batch
@python_buffers
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


# rows of `TrafficHistory.obs` (one column per car): what an undisturbed world's step k tests
# against its ego car, as `motion._obstacles` does: the car checks (a live car, not under
# external control), its position then, heading, direction to its next waypoint, safety box
O_CHECK, O_X, O_Z, O_FX, O_FZ, O_UX, O_UZ, O_FSAFE, O_LAT = range(9)
N_OBS = 9
TIME_MISMATCH = -9  # codes[w]: an undisturbed world's time is not its history step's (a bug: raised)


@whole_batch
@python_buffers
@borrowing_kernel
def _shared_range(lo: int, hi: int, f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray,
                  light_xz: np.ndarray, ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray,
                  t: np.ndarray, ego: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray,
                  brake_light: np.ndarray, turn_signal: np.ndarray, net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray,
                  codes: np.ndarray, rows: np.ndarray, shared: np.ndarray, kw: np.ndarray, h_len: int, hf: np.ndarray, hi_: np.ndarray,
                  hb: np.ndarray, hpos: np.ndarray, hend: np.ndarray, hlight: np.ndarray, hext: np.ndarray, hobs: np.ndarray,
                  ht: np.ndarray) -> int:  # fmt: skip
    """`_worlds_range`, with undisturbed worlds (`shared`, at step kw[w] of the history) taken
    from the history: a world whose ego car no car's safety box holds at this step moves its
    cars exactly as the history's world did (the step's only input from the ego car is that
    test, `motion._obstacles`; time and state are the history's), so it takes the next
    entry's positions, headings, speeds and enabled flags; a world whose ego car is seen
    (or that reached the history's end) gets the full state of its step from the history and
    steps itself from now on. Returns how many worlds stopped for Python."""
    left = 0
    for w in range(lo, hi):
        a, z = w * c, (w + 1) * c
        if not live[w]:
            codes[w] = NOTHING_LIVE
            for k in range(a, z):
                flags[k] = 0
            continue
        if shared[w]:
            k = kw[w]
            if t[w] != ht[k]:
                codes[w] = TIME_MISMATCH
                left += 1
                continue
            seen = k + 1 >= h_len
            ex, ez = ego[0, w], ego[1, w]
            for j in range(c):
                if seen:
                    break
                if hobs[k, O_CHECK, j] != 0.0:
                    seen = _sees(hobs[k, O_X, j], hobs[k, O_Z, j], hobs[k, O_FX, j], hobs[k, O_FZ, j], hobs[k, O_UX, j], hobs[k, O_UZ, j],
                                 hobs[k, O_FSAFE, j], hobs[k, O_LAT, j], ex, ez)  # fmt: skip
            if not seen:
                n1 = k + 1
                for j in range(c):
                    r = a + j
                    pos[r, 0], pos[r, 1], pos[r, 2] = hpos[n1, j, 0], hpos[n1, j, 1], hpos[n1, j, 2]
                    f[F_YAW, r], f[F_SPEED, r], b[B_ENABLED, r] = hf[n1, F_YAW, j], hf[n1, F_SPEED, j], hb[n1, B_ENABLED, j]
                    flags[r] = 0
                kw[w] = n1
                codes[w] = 0
                continue
            shared[w] = False
            _history_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, a, c, k, hf, hi_, hb, hpos, hend, hlight, hext, True)
        code, _ = step_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego, dt, work, flags, stop_mask, brake_light,
                            turn_signal, net, quiet, c, rows, a, z)  # fmt: skip
        codes[w] = code
        if code != 0 and code != NOTHING_LIVE:
            left += 1
    return left


def _shared_range_numpy(lo: int, hi: int, f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray,
                       light_xz: np.ndarray, ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray,
                       t: np.ndarray, ego: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray,
                       brake_light: np.ndarray, turn_signal: np.ndarray, net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray,
                       codes: np.ndarray, rows: np.ndarray, shared: np.ndarray, kw: np.ndarray, h_len: int, hf: np.ndarray,
                       hi_: np.ndarray, hb: np.ndarray, hpos: np.ndarray, hend: np.ndarray, hlight: np.ndarray, hext: np.ndarray,
                       hobs: np.ndarray, ht: np.ndarray) -> int:  # fmt: skip
    """`_shared_range` as numpy, what a cold cache runs instead of its Python twin
    (`jit.python_stand_in`). Why: as Python, the twin tests and copies an undisturbed world's
    41 cars one element at a time, ~70 us a world and physics step, 1.6 s of a cold 4,096-env
    MotorwayTask step. Here all the worlds that end no different from the history (live,
    shared, at the history's time, their ego car in no safety box) take the next entry at
    once: `motion._sees` written as array operations (the same operations on each element,
    so the same floats and decisions), then the copy. Every other world (not live, stepping
    itself, seen now, or at the history's end) goes to the twin, in runs of adjacent worlds:
    worlds share no rows, so the order does not matter."""
    args = (f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego, dt, work, flags, stop_mask, brake_light, turn_signal, net,
            quiet, c, live, codes, rows, shared, kw, h_len, hf, hi_, hb, hpos, hend, hlight, hext, hobs, ht)  # fmt: skip
    worlds = np.arange(lo, hi)
    cand = worlds[live[lo:hi] & shared[lo:hi]]
    k = kw[cand]
    cand_ok = (k + 1 < h_len) & (t[cand] == ht[np.minimum(k, len(ht) - 1)])
    cand, k = cand[cand_ok], k[cand_ok]
    obs = hobs[k]  # (worlds, N_OBS, c)
    ex, ez = ego[0, cand][:, None], ego[1, cand][:, None]
    x, z, fx, fz, ux, uz = obs[:, O_X], obs[:, O_Z], obs[:, O_FX], obs[:, O_FZ], obs[:, O_UX], obs[:, O_UZ]
    fsafe, lat = obs[:, O_FSAFE], obs[:, O_LAT]
    rx, rz = ex - x, ez - z
    reach = fsafe + lat
    f1, f2 = rx * fx + rz * fz, rx * ux + rz * uz
    sees = (rx * rx + rz * rz < reach * reach) & (
        ((np.abs(rx * fz - rz * fx) < lat) & (f1 > 0.0) & (f1 < fsafe)) | ((np.abs(rx * uz - rz * ux) < lat) & (f2 > 0.0) & (f2 < fsafe))
    )
    free = ~(sees & (obs[:, O_CHECK] != 0.0)).any(axis=1)
    cand, n1 = cand[free], k[free] + 1
    r = (cand * c)[:, None] + np.arange(c)
    pos[r] = hpos[n1]
    f[F_YAW, r], f[F_SPEED, r], b[B_ENABLED, r] = hf[n1, F_YAW], hf[n1, F_SPEED], hb[n1, B_ENABLED]
    flags[r] = 0
    kw[cand], codes[cand] = n1, 0
    rest = np.ones(hi - lo, dtype=bool)
    rest[cand - lo] = False
    left, twin = 0, python_twin(_shared_range)
    edges = np.flatnonzero(np.diff(np.concatenate(([False], rest, [False])).astype(np.int8)))
    for start, end in zip(edges[0::2].tolist(), edges[1::2].tolist(), strict=True):
        left += twin(lo + start, lo + end, *args)
    return left


python_stand_in(_shared_range, _shared_range_numpy)


@inline
def _history_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                  ext_cmd: np.ndarray, a: int, c: int, k: int, hf: np.ndarray, hi_: np.ndarray, hb: np.ndarray, hpos: np.ndarray,
                  hend: np.ndarray, hlight: np.ndarray, hext: np.ndarray, whole: bool) -> None:  # fmt: skip
    """Rows a..a+c-1 of the state := history entry k: all of it (`whole`), or what the
    nearby-vehicle slots read besides the rows `_shared_range` keeps (`motion.outputs`'s)."""
    for j in range(c):
        r = a + j
        if not whole:
            for q in (I_TURN_PATH, I_BRAKE_PATH, I_OV_BRAKE, I_OV_TURN):
                i[q, r] = hi_[k, q, j]
            b[B_BRAKING, r] = hb[k, B_BRAKING, j]
        else:
            for q in range(hi_.shape[1]):
                i[q, r] = hi_[k, q, j]
            for q in range(hb.shape[1]):
                b[q, r] = hb[k, q, j]
            for q in range(hf.shape[1]):
                f[q, r] = hf[k, q, j]
            for q in range(3):
                pos[r, q], ext_cmd[r, q] = hpos[k, j, q], hext[k, j, q]
            for q in range(2):
                end_xz[r, q], light_xz[r, q] = hend[k, j, q], hlight[k, j, q]


@whole_batch
@python_buffers
@borrowing_kernel
def history_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                 ext_cmd: np.ndarray, c: int, shared: np.ndarray, kw: np.ndarray, hf: np.ndarray, hi_: np.ndarray, hb: np.ndarray,
                 hpos: np.ndarray, hend: np.ndarray, hlight: np.ndarray, hext: np.ndarray, whole: bool) -> None:  # fmt: skip
    """`_history_rows` for every `shared` world, each at its own entry kw[w]."""
    for w in range(len(shared)):
        if shared[w]:
            _history_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, w * c, c, kw[w], hf, hi_, hb, hpos, hend, hlight, hext, whole)


@parallel_kernel
def step_shared(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t: np.ndarray, ego: np.ndarray,
                dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray,
                net: np.ndarray, quiet: np.ndarray, c: int, live: np.ndarray, codes: np.ndarray, rows: np.ndarray, shared: np.ndarray,
                kw: np.ndarray, h_len: int, hf: np.ndarray, hi_: np.ndarray, hb: np.ndarray, hpos: np.ndarray, hend: np.ndarray,
                hlight: np.ndarray, hext: np.ndarray, hobs: np.ndarray, ht: np.ndarray) -> int:  # fmt: skip
    """`_shared_range` over all worlds, chunks on numba's threads."""
    n = len(live)
    chunks = chunk_count(n)
    left = np.zeros(chunks, dtype=np.int64)
    for k in prange(chunks):
        left[k] = _shared_range(k * n // chunks, (k + 1) * n // chunks, f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego,
                                dt, work, flags, stop_mask, brake_light, turn_signal, net, quiet, c, live, codes, rows, shared, kw, h_len,
                                hf, hi_, hb, hpos, hend, hlight, hext, hobs, ht)  # fmt: skip
    return int(left.sum())
