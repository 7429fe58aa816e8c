"""The physics steps of one Lane Change Test policy step, for all envs, as one compiled call.

Why: `BatchCore._physics_steps` runs each physics step as a handful of kernels with numpy
and Python between them (six times per policy step). That Python holds the GIL, so shards
stepped in threads mostly waited for each other. Here one kernel runs the whole loop (ego
car, trigger contacts, reaction timers, lane measures, trace rows, the LCT's path measures,
early stop) with the same per-car functions as those kernels (`vector.ego.ego_step_wheels`,
`kernels.*`, `lct_measure` below), so the results are the same floats. A car that touches a
trigger box fires the trigger's actions in the pass (`lct_fire.fire_inline`); only where that
would log a reaction result does it return to Python, which fires them and finishes the car in
a second call; reaction timers that end are scored by Python afterwards.

The per-chunk loops are `jit.borrowing_kernel`s (no reference counting: they allocate
nothing): every inlined helper that takes arrays (the trigger search and contact test, the
lane measures) updated their reference counts atomically at each physics step (~10 % of
the pass's CPU time on one thread, 4,096 envs, measured against the code before).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import prange

from ..jit import borrowing_kernel, inline, kernel, parallel_kernel, python_buffers
from ..sim.ego.kernels import wheel_constants
from ..sim.ego.spec import MAX_WHEEL_ANGLE_RAD
from .ego import ego_step_wheels
from .kernels import chunk_count, ego_features_row, lane_measures, nearest_volume, take_next, timer_step, volume_fires
from .lanes_known import lanes_known_at
from .lct_fire import fire_inline
from .sealed import seal, unseal
from .trace import TRACE_GROUP


@parallel_kernel
def lct_substeps(*args: Any) -> tuple[int, int]:
    """`_substeps_range` (`args`: its arguments after lo and hi) for all envs, chunk by chunk
    on numba's threads: (cars parked, most physics steps run). The loop's body takes the
    arguments as one sealed value (`sealed.seal`): numba lowers a parallel loop's body with
    each free variable as an argument, at a cost that grows faster than their number."""
    n = len(args[4])  # (live)
    chunks = chunk_count(n)
    parked, ran = np.zeros(chunks, dtype=np.int64), np.full(chunks, args[1], dtype=np.int64)
    sealed = seal(args)
    for c in prange(chunks):
        parked[c], ran[c] = _substeps_chunk(c * n // chunks, (c + 1) * n // chunks, sealed)
    return parked.sum(), ran.max()


@borrowing_kernel
def _substeps_chunk(lo: int, hi: int, args: Any) -> tuple[int, int]:
    """`_substeps_range` of the envs lo..hi-1, its other arguments sealed (`lct_substeps`)."""
    return _substeps_range(lo, hi, *unseal(args))


@python_buffers
@borrowing_kernel
def _substeps_range(lo: int, hi: int, resume: bool, k_from: int, k_to: int, dt: float, live: np.ndarray, park: np.ndarray,
                 step_count: np.ndarray, t: np.ndarray,
                 paused: np.ndarray, car: np.ndarray, engine_on: bool, suppress_cruise_off: bool, min_speed: float, ego: tuple,
                 gear: np.ndarray, cruise_on: np.ndarray, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray, shift: float, hx: float,
                 hz: float, vols: np.ndarray, vol_triggers: np.ndarray, locks: np.ndarray, near: np.ndarray, contact: np.ndarray,
                 timers: bool, active: np.ndarray, spec: np.ndarray, timer_f: tuple, braked: np.ndarray,
                 start_lane: np.ndarray, timer_table: np.ndarray, bands: np.ndarray, done: np.ndarray, done_t: np.ndarray, sign: float,
                 centres: np.ndarray, half_width: float, keep_m: float, lat: np.ndarray, lane: np.ndarray, offset: np.ndarray,
                 sdlp: tuple, ring: bool, block_a: np.ndarray, block_b: np.ndarray, row0: int, ring_steps: np.ndarray, start_z: float,
                 norm: np.ndarray, d0: float, norm_step: float, scale: float, has_prev: np.ndarray, path: tuple, off_road: float,
                 steering: tuple, fire: tuple) -> tuple[int, int]:  # fmt: skip
    """Physics steps k_from..k_to-1 of the policy step for the envs lo..hi-1 that are `live`
    (cleared for those that stop early), car by car: each car's state stays in registers for
    its steps (`lct_substeps`: all envs, chunks on numba's threads).

    A car that touches a trigger box in its physics step k fires its triggers there
    (`fire_inline`, `fire`: `lct_fire.fire_tables` and the trigger state) or, where Python
    must, is parked there (`park[e] = k`, `contact[e]` the volume; -1 otherwise) for Python
    to fire them; a call with
    `resume` then goes on with the parked cars only, after their contact test. Returns (cars
    parked, the most physics steps a finished car ran, counted from the policy step's first;
    trace row k goes to row `row0 + k` of the two blocks). The tuples hold float arrays: `ego`
    (x, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in,
    cruise_target, cruise_int), `timer_f` (start_t, start_x, start_z, peak, hold_since, tlim, dlim),
    `sdlp` (n, mean, m2), `path` (prev_d, prev_dev, area, reward), `steering` (each car's
    steering angle, its cosine and sine: the steering is held for the policy step); trace
    rows are (x, z, u, steer_in), in grouped blocks (`TraceRing(grouped=True)`).
    """
    x, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in, cruise_target, cruise_int = ego
    timer_t, timer_x, timer_z, peak, hold_since, tlim, dlim = timer_f  # (not start_z: the LCT's start)
    sd_n, sd_mean, sd_m2 = sdlp
    prev_d, prev_dev, area, reward = path
    angle, cos_a, sin_a = steering
    block = block_a.shape[0] * TRACE_GROUP  # rows of a block (grouped: (BLOCK / TRACE_GROUP, n, TRACE_GROUP, column))
    parked, ran = 0, k_from
    for e in range(lo, hi):
        if not resume:
            contact[e] = -1
        if not live[e] or (resume and park[e] < 0):
            continue
        k, moved = (park[e], True) if resume else (k_from, False)
        park[e], contact[e] = -1, -1
        if not resume and k_from == 0:
            angle[e] = steer[e] * MAX_WHEEL_ANGLE_RAD
            cos_a[e], sin_a[e] = math.cos(angle[e]), math.sin(angle[e])
        wc = wheel_constants(car, dt, cos_a[e], sin_a[e])  # (the steering is held: once per car and call)
        # the car's state, kept in locals until it stops, parks or ends the policy step
        xe, ze, yawe, ue, ve, re, geare, rpme, pv, fu, fl = x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e], prev_v[e], \
            fuel_used[e], fuel_left[e]  # fmt: skip
        si, gi, bi, con, cint, sc, te = steer_in[e], gas_in[e], brake_in[e], cruise_on[e], cruise_int[e], step_count[e], t[e]
        la, ln, off, sn, sm, sm2, nr, rs = lat[e], lane[e], offset[e], sd_n[e], sd_mean[e], sd_m2[e], near[e], ring_steps[e]
        pd, pdev, ar, rw, hp = prev_d[e], prev_dev[e], area[e], reward[e], has_prev[e]
        while k < k_to:
            if not moved:
                sc += 1
                te = sc * dt
                u0, si = ue, steer[e]
                xe, ze, yawe, ue, ve, re, geare, rpme, fu, fl, con, cint, gi, bi, sy, cy = ego_step_wheels(
                    car, wc, engine_on, suppress_cruise_off, min_speed, dt, xe, ze, yawe, ue, ve, re, geare, rpme, pv, fu, fl, con,
                    cruise_target[e], cint, cos_a[e], sin_a[e], gas[e], brake[e],
                )  # fmt: skip
                pv = u0
                if not paused[e]:
                    bx, bz = xe - shift * sy, ze - shift * cy  # (`kernels.box_centre`)
                    j, nr = nearest_volume(bx, bz, vols, nr)
                    if (j >= 0 and volume_fires(e, j, bx, bz, yawe, hx, hz, vols, vol_triggers, te, locks)
                            and not fire_inline(e, j, te, xe, ze, ue, fire, locks, paused, active, done, spec, timer_f, braked,
                                                start_lane, timer_table, bands)):  # fmt: skip
                        park[e], contact[e] = k, j  # (Python fires them)
                        break
            moved = False
            if timers and active[e] and not paused[e]:
                how, peak[e], braked[e], hold_since[e] = timer_step(
                    timer_table, bands, spec[e], timer_t[e], timer_x[e], timer_z[e], tlim[e], dlim[e], peak[e], hold_since[e], braked[e],
                    start_lane[e], te, xe, ze, ue, si, bi,
                )  # fmt: skip
                if how:
                    active[e], done[e], done_t[e] = False, how, te
            la, ln, off, sn, sm, sm2, _, _ = lane_measures(
                xe, ze, False, sign, centres, half_width, keep_m, off, sn, sm, sm2, False, 0.0, 0.0, 0.0, 0.0
            )
            if ring:
                row = row0 + k
                out, i = (block_a, row) if row < block else (block_b, row - block)
                grp, slot = i // TRACE_GROUP, i % TRACE_GROUP  # (a grouped ring: `TraceRing`)
                out[grp, e, slot, 0], out[grp, e, slot, 1], out[grp, e, slot, 2], out[grp, e, slot, 3] = xe, ze, ue, si
                rs += 1
            pd, pdev, ar, rw = lct_measure(ze, la, start_z, norm, d0, norm_step, scale, hp, pd, pdev, ar, rw)
            hp = True
            k += 1
            if paused[e] or abs(la) > off_road:
                live[e] = False
                break
        x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e], prev_v[e], fuel_used[e], fuel_left[e] = xe, ze, yawe, ue, ve, re, geare, \
            rpme, pv, fu, fl  # fmt: skip
        steer_in[e], gas_in[e], brake_in[e], cruise_on[e], cruise_int[e], step_count[e], t[e] = si, gi, bi, con, cint, sc, te
        lat[e], lane[e], offset[e], sd_n[e], sd_mean[e], sd_m2[e], near[e], ring_steps[e] = la, ln, off, sn, sm, sm2, nr, rs
        prev_d[e], prev_dev[e], area[e], reward[e], has_prev[e] = pd, pdev, ar, rw, hp
        if park[e] >= 0:
            parked += 1
        elif k > ran:
            ran = k
    return parked, ran


@inline
def lct_measure(z: float, lat: float, start_z: float, norm: np.ndarray, d0: float, step: float, scale: float, has_prev: bool,
                prev_d: float, prev_dev: float, area: float, reward: float) -> tuple[float, float, float, float]:  # fmt: skip
    """`LaneChangeTestEnv._on_physics_step` at (z, lateral position lat): the distance driven
    and the deviation from the normative path (sampled every `step` metres from `d0`), the
    area between the two paths (trapezoids) and the reward's share of the step (m)."""
    d = start_z - z
    i = int((d - d0) / step)  # int(): towards zero
    ideal = norm[0] if i < 0 else norm[len(norm) - 1] if i >= len(norm) else norm[i]
    dev = abs(lat - ideal)
    if has_prev:
        mid = 0.5 * (dev + prev_dev)
        dd = d - prev_d
        area = area + mid * dd
        share = 1.0 - mid / scale
        reward = reward + (share if share > 0.0 else 0.0) * dd
    return d, dev, area, reward


@parallel_kernel
def lct_observation(out: np.ndarray, u: np.ndarray, yaw: np.ndarray, heading: float, offset: np.ndarray, lat: np.ndarray,
                    lane: np.ndarray, steer: np.ndarray, r: np.ndarray, z: np.ndarray, revealed: np.ndarray, sign_z: np.ndarray,
                    sign_lane: np.ndarray, lane_lat: np.ndarray) -> None:  # fmt: skip
    """The LCT's kinematics observation of every env (float32): the ego features
    (`kernels.ego_features_row`), zeros for the vehicle slots, then the stimulus of
    `LaneChangeTestEnv._stimulus`: the revealed sign's visibility, the lateral gap to its lane
    and the distance driven past it (m)."""
    n = len(u)
    chunks = chunk_count(n)
    for c in prange(chunks):
        _observation_range(c * n // chunks, (c + 1) * n // chunks, out, u, yaw, heading, offset, lat, lane, steer, r, z, revealed,
                           sign_z, sign_lane, lane_lat)  # fmt: skip


@borrowing_kernel
def _observation_range(lo: int, hi: int, out: np.ndarray, u: np.ndarray, yaw: np.ndarray, heading: float, offset: np.ndarray,
                       lat: np.ndarray, lane: np.ndarray, steer: np.ndarray, r: np.ndarray, z: np.ndarray, revealed: np.ndarray,
                       sign_z: np.ndarray, sign_lane: np.ndarray, lane_lat: np.ndarray) -> None:  # fmt: skip
    """`lct_observation` for the envs lo..hi-1."""
    width = out.shape[1]
    for e in range(lo, hi):
        ego_features_row(out, e, u[e], yaw[e], heading, offset[e], lat[e], lane[e], steer[e], r[e])
        for i in range(7, width - 3):
            out[e, i] = 0.0
        k = revealed[e]
        distance = 0.0
        if k >= 0:
            d = z[e] - sign_z[k]
            distance = 0.0 if d < 0.0 else d  # (np.maximum: NaN stays NaN)
        target = sign_lane[k] if k >= 0 else sign_lane[len(sign_lane) - 1]
        out[e, width - 3] = 1.0 if k >= 0 and distance > 0.0 else 0.0
        out[e, width - 2] = lane_lat[target] - lat[e]
        out[e, width - 1] = distance


@parallel_kernel
def lct_outcomes(*args: Any) -> None:
    """`_outcomes_range` (`args`: its arguments after lo and hi) for all envs, chunk by chunk
    on numba's threads (the loop's body takes the arguments sealed, as `lct_substeps`')."""
    n = len(args[3])  # (z)
    chunks = chunk_count(n)
    sealed = seal(args)
    for c in prange(chunks):
        _outcomes_chunk(c * n // chunks, (c + 1) * n // chunks, sealed)


@borrowing_kernel
def _outcomes_chunk(lo: int, hi: int, args: Any) -> None:
    """`_outcomes_range` of the envs lo..hi-1, its other arguments sealed (`lct_outcomes`)."""
    _outcomes_range(lo, hi, *unseal(args))


@borrowing_kernel
def _outcomes_range(lo: int, hi: int, rows: np.ndarray, sign: float, origin_z: float, z: np.ndarray, u: np.ndarray, last_s: np.ndarray,
                 progress: np.ndarray, collisions: np.ndarray, collisions_seen: np.ndarray, new_collisions: np.ndarray,
                 n_results: np.ndarray, cursor: np.ndarray, last_result: np.ndarray, last_rt: np.ndarray, sd_n: np.ndarray,
                 sd_m2: np.ndarray, has_prev: np.ndarray, prev_d: np.ndarray, area: np.ndarray, lat: np.ndarray, off_road: float,
                 step_reward: np.ndarray, reward_scale: float, penalty: float, paused: np.ndarray, terminate_on_collision: bool,
                 t: np.ndarray, max_s: float, info_f: tuple, info_i: tuple, reward: np.ndarray, terminated: np.ndarray,
                 truncated: np.ndarray) -> None:  # fmt: skip
    """The end of `BatchCore.step_rows` for the LCT in one pass: progress along the road,
    new collisions, the info values (`info_f`: speed_kmh, reaction_result, reaction_time_s,
    mean_deviation_m, sdlp_m, progress_m; `info_i`: new_collisions), the reward (which
    empties `step_reward`) and the episode flags of the envs lo..hi-1 that are `rows` (the
    others: reward 0, flags False), with the formulas of `BatchCore.info`,
    `LaneChangeTestEnv._reward` and `_task_terminated`, and `BatchCore._terminated`."""
    speed_kmh, result, rt, mdev, sdlp, progress_m = info_f
    (new_coll_out,) = info_i
    for e in range(lo, hi):
        s_now = -sign * (z[e] - origin_z)
        progress[e] = s_now - last_s[e] if rows[e] else 0.0
        if rows[e]:
            last_s[e] = s_now
        new_collisions[e] = collisions[e] - collisions_seen[e] if rows[e] else 0
        collisions_seen[e] = collisions[e]
        fresh = n_results[e] > cursor[e]
        result[e] = last_result[e] if fresh else 0.0
        rt[e] = last_rt[e] if fresh else 0.0
        cursor[e] = n_results[e]
        speed_kmh[e] = u[e] * 3.6
        n = sd_n[e]
        sdlp[e] = math.sqrt(sd_m2[e] / (n if n > 1.0 else 1.0)) if n >= 2 else 0.0
        dist = prev_d[e] if has_prev[e] else 0.0
        mdev[e] = area[e] / dist if dist > 0 else 0.0
        progress_m[e] = progress[e]
        new_coll_out[e] = new_collisions[e]
        task_end = abs(lat[e]) > off_road
        r = reward_scale * step_reward[e]
        step_reward[e] = 0.0
        if task_end:
            r = r - penalty
        r = r - 10.0 * float(new_collisions[e])
        ended = paused[e] or task_end or (terminate_on_collision and new_collisions[e] > 0)
        reward[e] = r if rows[e] else 0.0
        terminated[e] = ended and rows[e]
        truncated[e] = not ended and t[e] >= max_s - 1e-9 and rows[e]


# rows of the float and int blocks `lct_finish` fills: the info arrays of one policy step, in `BatchCore.info`'s key order
INFO_F = ("sim_time_s", "speed_kmh", "lateral_offset_m", "fuel_used_l", "reaction_result", "reaction_time_s", "mean_deviation_m",
          "sdlp_m", "headway_s", "ttc_s", "reset_time_s", "progress_m")  # fmt: skip
INFO_I = ("lane_index", "collisions", "resets", "new_collisions")


@parallel_kernel
def lct_finish(outcome: tuple, obs: tuple, copies: tuple, info_f: np.ndarray, info_i: np.ndarray, known: np.ndarray,
               lanes: tuple[bool, float]) -> None:  # fmt: skip
    """The end of a policy step in one parallel pass: `lct_outcomes` (its arguments `outcome`,
    less its info tuples: rows of `info_f` and `info_i` take them), `lct_observation` (its
    arguments `obs`) and the info arrays that are copies of the state (`copies`: t, offset,
    fuel_used, headway, ttc as floats; lane, collisions as ints), so a step's info is two
    blocks filled in compiled code (rows named by INFO_F and INFO_I) and `known`. (The loop's
    body takes the arguments sealed, as `lct_substeps`'.)"""
    n = info_f.shape[1]
    chunks = chunk_count(n)
    sealed = seal((outcome, obs, copies, info_f, info_i, known, lanes))
    for c in prange(chunks):
        _finish_chunk(c * n // chunks, (c + 1) * n // chunks, sealed)


@borrowing_kernel
def _finish_chunk(lo: int, hi: int, args: Any) -> None:
    """`_finish_range` of the envs lo..hi-1, its other arguments sealed (`lct_finish`)."""
    _finish_range(lo, hi, *unseal(args))


@borrowing_kernel
def _finish_range(lo: int, hi: int, outcome: tuple, obs: tuple, copies: tuple, info_f: np.ndarray, info_i: np.ndarray, known: np.ndarray,
                  lanes: tuple[bool, float]) -> None:  # fmt: skip
    """`lct_finish` for the envs lo..hi-1."""
    rows, sign, origin_z, z, u, last_s, progress, collisions, collisions_seen, new_collisions, n_results, cursor, last_result, \
        last_rt, sd_n, sd_m2, has_prev, prev_d, area, lat, off_road, step_reward, reward_scale, penalty, paused, \
        terminate_on_collision, t, max_s, reward, terminated, truncated = outcome  # fmt: skip
    floats = (info_f[1], info_f[4], info_f[5], info_f[6], info_f[7], info_f[11])
    _outcomes_range(lo, hi, rows, sign, origin_z, z, u, last_s, progress, collisions, collisions_seen, new_collisions, n_results, cursor,
                    last_result, last_rt, sd_n, sd_m2, has_prev, prev_d, area, lat, off_road, step_reward, reward_scale, penalty, paused,
                    terminate_on_collision, t, max_s, floats, (info_i[3],), reward, terminated, truncated)  # fmt: skip
    out, o_u, yaw, heading, offset, o_lat, lane, steer, r, o_z, revealed, sign_z, sign_lane, lane_lat = obs
    _observation_range(lo, hi, out, o_u, yaw, heading, offset, o_lat, lane, steer, r, o_z, revealed, sign_z, sign_lane, lane_lat)
    c_t, c_offset, c_fuel, c_headway, c_ttc, c_lane, c_collisions = copies
    for e in range(lo, hi):
        info_f[0, e], info_f[2, e], info_f[3, e], info_f[8, e], info_f[9, e], info_f[10, e] = c_t[e], c_offset[e], c_fuel[e], \
            c_headway[e], c_ttc[e], 0.0  # fmt: skip
        info_i[0, e], info_i[1, e], info_i[2, e] = c_lane[e], c_collisions[e], 0
        known[e] = lanes_known_at(lanes, last_s[e])  # (`vector.lanes_known`: lanes = known_from(guide))


@parallel_kernel
def lct_step(workers: int, a: np.ndarray, resetting: np.ndarray, rows: np.ndarray, finished: np.ndarray, lists: np.ndarray,
             counts: np.ndarray, prep: tuple, sub: tuple, fin: tuple) -> tuple[int, int, int]:  # fmt: skip
    """A whole policy step with NEXT_STEP autoreset in one parallel pass: the actions of the
    stepping envs checked (before any env moves), then chunk by chunk the resets and controls
    (`_prepare_range`, its arguments `prep`), the physics steps (`_substeps_range`, `sub`:
    its arguments after lo and hi, not resuming, from physics step 0) and, where no car of the
    chunk waits for Python (a parked car or a reaction timer that ended), the step's outputs
    (`_finish_range`, `fin`; `finished[c]` set). Each of numba's threads (`workers`: their
    number) takes chunks one at a time until none is left (`kernels.take_next`). The envs
    reset go to row 0 of `lists`, those whose episode ended in a finished chunk to row 1, in
    no order (`counts[1]`, `counts[2]`: how many). Returns (the first env whose action holds
    NaN or infinity, -1: none, and then nothing ran; cars parked; most physics steps run).

    The loop's body takes one value, all the arguments `sealed` (`sealed.seal`), and hands
    it to `_take_chunks`: numba lowers a parallel loop's body with each free variable as an
    argument, at a cost that grows faster than their number (see `sealed`)."""
    n = len(resetting)
    bad = _first_bad(a, resetting)
    if bad >= 0:
        return bad, 0, 0
    chunks = chunk_count(n)
    parked_c, ran_c = np.zeros(chunks, dtype=np.int64), np.zeros(chunks, dtype=np.int64)
    counts[0], counts[1], counts[2] = 0, 0, 0  # chunks handed out, envs listed in rows 0 and 1 of `lists`
    args = seal((a, resetting, rows, finished, lists, counts, prep, sub, fin, parked_c, ran_c))
    for _ in prange(min(workers, chunks)):
        _take_chunks(args)
    return -1, parked_c.sum(), ran_c.max()


@borrowing_kernel
def _take_chunks(args: Any) -> None:
    """One thread's share of `lct_step` (its arguments sealed): chunks taken one at a time
    (`kernels.take_next`) until none is left, each stepped by `_step_chunk`."""
    a, resetting, rows, finished, lists, counts, prep, sub, fin, parked_c, ran_c = unseal(args)
    n, chunks = len(resetting), len(parked_c)
    while True:
        c = take_next(counts, 0)
        if c >= chunks:
            break
        lo, hi = c * n // chunks, (c + 1) * n // chunks
        parked_c[c], ran_c[c], finished[c] = _step_chunk(lo, hi, a, resetting, rows, lists, counts, prep, sub, fin)


@kernel
def lct_step_serial(workers: int, a: np.ndarray, resetting: np.ndarray, rows: np.ndarray, finished: np.ndarray, lists: np.ndarray,
                    counts: np.ndarray, prep: tuple, sub: tuple, fin: tuple) -> tuple[int, int, int]:  # fmt: skip
    """`lct_step` in this thread, as one chunk (a batch of one chunk, or stepped in a Python thread; `workers` unused)."""
    bad = _first_bad(a, resetting)
    if bad >= 0:
        return bad, 0, 0
    counts[0], counts[1], counts[2] = 0, 0, 0
    parked, ran, finished[0] = _step_chunk(0, len(resetting), a, resetting, rows, lists, counts, prep, sub, fin)
    return -1, parked, ran


@kernel
def finish_chunks(finished: np.ndarray, n: int, lists: np.ndarray, counts: np.ndarray, outcome: tuple, obs: tuple, copies: tuple,
                  info_f: np.ndarray, info_i: np.ndarray, known: np.ndarray, lanes: tuple[bool, float]) -> None:  # fmt: skip
    """`_finish_range` of the chunks of n envs (`chunk_count`, or one) that `lct_step` did not
    finish (`finished`), after Python fired their parked cars' triggers and scored their
    timers; their ended envs listed as `lct_step` lists them."""
    chunks = len(finished)
    for c in range(chunks):
        if not finished[c]:
            lo, hi = c * n // chunks, (c + 1) * n // chunks
            _finish_range(lo, hi, outcome, obs, copies, info_f, info_i, known, lanes)
            _list_ended(lo, hi, outcome, lists, counts)


@borrowing_kernel
def _first_bad(a: np.ndarray, resetting: np.ndarray) -> int:
    """`actions.first_nonfinite` of the envs not `resetting`."""
    for e in range(a.shape[0]):
        if not resetting[e]:
            for j in range(a.shape[1]):
                if not math.isfinite(a[e, j]):
                    return e
    return -1


@borrowing_kernel
def _step_chunk(lo: int, hi: int, a: np.ndarray, resetting: np.ndarray, rows: np.ndarray, lists: np.ndarray, counts: np.ndarray,
                prep: tuple, sub: tuple, fin: tuple) -> tuple[int, int, bool]:  # fmt: skip
    """`lct_step` for the envs lo..hi-1: (cars parked, most physics steps run, outputs written)."""
    _prepare_range(lo, hi, a, resetting, rows, *prep)
    for e in range(lo, hi):
        if resetting[e]:
            lists[0, take_next(counts, 1)] = e
    parked, ran = _substeps_range(lo, hi, False, 0, *sub)
    done = sub[33]  # (`timers.done`: a timer that ended is scored by Python first)
    for e in range(lo, hi):
        if done[e]:
            return parked, ran, False
    if parked:
        return parked, ran, False
    _finish_range(lo, hi, *fin)
    _list_ended(lo, hi, fin[0], lists, counts)
    return parked, ran, True


@borrowing_kernel
def _list_ended(lo: int, hi: int, outcome: tuple, lists: np.ndarray, counts: np.ndarray) -> None:
    """The envs lo..hi-1 whose episode ended (`outcome`'s terminated and truncated, its last
    two) into row 1 of `lists` (`lct_step`)."""
    terminated, truncated = outcome[29], outcome[30]
    for e in range(lo, hi):
        if terminated[e] or truncated[e]:
            lists[1, take_next(counts, 2)] = e


@borrowing_kernel
def _prepare_range(lo: int, hi: int, a: np.ndarray, resetting: np.ndarray, rows: np.ndarray, live: np.ndarray, controls: tuple,
                   held: np.ndarray, pose: tuple, initial: tuple, ego: tuple, gear: np.ndarray, cruise_on: np.ndarray, trig: tuple,
                   timer: tuple, counters: tuple, measures: tuple, task: tuple, road: tuple, lanes: tuple, ring: bool, first: tuple,
                   ring_steps: np.ndarray, ring_start: tuple, draws: np.ndarray) -> None:  # fmt: skip
    """Before the physics steps of the envs lo..hi-1: the controls of those that step (the
    floats of `actions.continuous_controls`, and the buttons held of `BatchActions.convert`),
    `rows` and `live` set (True: it steps), and `BatchCore.reset_rows` (seed None) of those
    `resetting`, with `LctBatch._reset_task`: the world seed drawn later (`draws`, see
    `BatchCore._world_seed`), the car at its start (`ego.reset_rows`), triggers, timers
    (`TimerBatch.reset_rows`, less its Python lists), counters, lane measures and trace
    reset row (`_record_row(first=True)`, `ring_start`: the ring's `start` and the row g after
    the policy step, which the caller corrects when no car ran all its physics steps)."""
    steer, gas, brake = controls
    x, y, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in, cruise_target, cruise_int = ego
    locks, counts, paused, started, started_at = trig
    active, kind, n_results = timer
    step_count, collisions, collisions_seen, cursor, new_collisions = counters
    t, progress, rl_n, rl_mean, rl_m2, rl_area, rl_dist, area, step_reward = measures
    revealed, has_prev, last_s = task
    sign, origin_z = road
    centres, half_width, keep_m, lat, lane, offset = lanes
    first_x, first_z, first_u, first_steer = first
    px, py, pz, pyaw = pose
    speed, gear0, rpm0, fuel0 = initial
    start, g_end = ring_start
    width = a.shape[1]
    for e in range(lo, hi):
        if not resetting[e]:
            rows[e], live[e] = True, True
            s, p = a[e, 0], a[e, 1]
            steer[e] = -1.0 if s < -1.0 else 1.0 if s > 1.0 else s
            p = -1.0 if p < -1.0 else 1.0 if p > 1.0 else p
            gas[e] = p if p > 0.0 or p != p else 0.0
            brake[e] = -p if -p > 0.0 or p != p else 0.0
            for j in range(2, width):
                held[e, j - 2] = a[e, j] > 0.0
            continue
        rows[e], live[e] = False, False
        for j in range(2, width):
            held[e, j - 2] = False
        draws[e] += 1
        x[e], y[e], z[e], yaw[e] = px, py, pz, pyaw
        u[e], v[e], r[e] = speed, 0.0, 0.0
        gear[e], rpm[e], prev_v[e] = gear0, rpm0, speed
        fuel_used[e], fuel_left[e] = 0.0, fuel0
        steer_in[e], gas_in[e], brake_in[e] = 0.0, 0.0, 0.0
        cruise_on[e], cruise_target[e], cruise_int[e] = speed > 0.0, speed, 0.0
        for i in range(locks.shape[1]):
            locks[e, i] = -math.inf
        for i in range(counts.shape[1]):
            counts[e, i] = 0
        paused[e], started[e], started_at[e] = False, False, 0.0
        active[e], kind[e], n_results[e] = False, -1, 0
        step_count[e], collisions[e], collisions_seen[e], cursor[e], new_collisions[e] = 0, 0, 0, 0, 0
        t[e], progress[e], rl_area[e], rl_dist[e] = 0.0, 0.0, 0.0, 0.0
        last_s[e] = -sign * (z[e] - origin_z)
        revealed[e], area[e], step_reward[e], has_prev[e] = -1, 0.0, 0.0, False
        lat[e], lane[e], offset[e], rl_n[e], rl_mean[e], rl_m2[e], _, _ = lane_measures(
            x[e], z[e], True, sign, centres, half_width, keep_m, offset[e], 0.0, 0.0, 0.0, False, 0.0, 0.0, 0.0, 0.0
        )
        if ring:
            first_x[e], first_z[e], first_u[e], first_steer[e] = x[e], z[e], u[e], steer_in[e]
            ring_steps[e] = 0
            start[e] = g_end
