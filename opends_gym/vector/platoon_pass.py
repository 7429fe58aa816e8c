"""The physics steps of one brake or platoon test policy step, for all envs, as one compiled call.

Why: `BatchCore._physics_step` ran each physics step as separate calls (the ego car's
kernel, the traffic kernels, the trigger contacts, the reaction timers) with numpy and
Python between them, then `platoon_step.after_one`'s pass; six times per policy step. That
Python holds the GIL, so the batch kept about two cores busy at any thread count. Here one
kernel runs each env's whole policy step (`lct_step.lct_substeps` does so for the LCT):
the ego car (`vector.ego.ego_step_wheels`), its world's traffic cars (`motion.step_rows`,
the kernel `TrafficManager.step` runs for one world, so each world's carrots are resampled
only when one of *its* legs moved on, as in its single env), the trigger contact test, the
reaction timers and `after_one`; chunks of envs on numba's threads. The same per-car
functions as before, so the same floats.

Two rare events need Python: a traffic car whose wait is over or whose leg ended (the
single env's `LegLogic`), and a trigger whose actions fire (`setTVPTStimulus` draws from
the env's own generator). The env is then parked at that point of that physics step
(`park[e]` the physics step, `stage[e]` TRAFFIC or FIRE), Python handles the event for
the parked envs only (`traffic_events`, `TriggerBatch.fire`), and a call with `resume`
goes on with them from there. Timers that end and stimuli that change result are flagged
in the pass and copied into Python's records after each call (before any trigger fires).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import prange

from ..jit import borrowing_kernel, inline, parallel_kernel, python_buffers
from ..sim.ego.kernels import wheel_constants
from ..sim.ego.spec import MAX_WHEEL_ANGLE_RAD
from ..sim.traffic.motion import ARRIVED, NOTHING_LIVE, WAIT_OVER, WAITS_OVER, advance_carrots, drive, step_rows
from .block_view import prefetch_write
from .ego import ego_step_wheels
from .kernels import V_CZ, V_REACH, armed_from, chunk_count, nearest_volume, timer_step, volume_touches
from .platoon_step import after_one
from .sealed import seal, unseal
from .trace import PLATOON_TRACE_GROUP

STEP, TRAFFIC, FIRE = 0, 1, 2  # where a parked env's physics step goes on (`stage`): Python finished its traffic, or fired its triggers
CLEAR_MARGIN_M = 1e-6  # what `_clear_of_volumes`' radius keeps to spare (its sums round by ~1e-13 m at road scale)


@parallel_kernel
def platoon_substeps(resume: bool, k_from: int, k_to: int, dt: float, live: np.ndarray, park: np.ndarray, stage: np.ndarray,
                     step_count: np.ndarray, controls: tuple, ego: tuple, traffic: tuple, trig: tuple, timers: tuple, a: tuple,
                     lead: tuple, lanes: tuple, ring: tuple, hook: tuple, band: tuple, stim: tuple, hits: tuple,
                     stop: tuple) -> tuple[int, int, int]:  # fmt: skip
    """Physics steps k_from..k_to-1 of the policy step for the envs `live` (cleared for those
    that stop early), env by env (see `_substeps_range`), chunks on numba's threads. Returns
    (envs parked, the most physics steps a finished env ran counted from the policy step's
    first, stimuli that changed result). The loop's body takes the arguments as one sealed
    value (`sealed.seal`, as `lct_step.lct_substeps` does): numba lowers a parallel loop's
    body with each free variable as an argument (a tuple's items each), at a cost that grows
    faster than their number, and the worker it calls unseals them without reference counts."""
    n = len(live)
    chunks = chunk_count(n)
    parked, ran, changed = np.zeros(chunks, dtype=np.int64), np.full(chunks, k_from, dtype=np.int64), np.zeros(chunks, dtype=np.int64)
    sealed = seal((resume, k_from, k_to, dt, live, park, stage, step_count, controls, ego, traffic, trig, timers, a, lead, lanes, ring,
                   hook, band, stim, hits, stop))  # fmt: skip
    for j in prange(chunks):
        parked[j], ran[j], changed[j] = _substeps_chunk(j * n // chunks, (j + 1) * n // chunks, sealed)
    return parked.sum(), ran.max(), changed.sum()


@borrowing_kernel
def _substeps_chunk(lo: int, hi: int, args: Any) -> tuple[int, int, int]:
    """`_substeps_range` of the envs lo..hi-1, its other arguments sealed (`platoon_substeps`)."""
    return _substeps_range(lo, hi, *unseal(args))


@python_buffers
@borrowing_kernel
def _substeps_range(lo: int, hi: int, resume: bool, k_from: int, k_to: int, dt: float, live: np.ndarray, park: np.ndarray,
                    stage: np.ndarray, step_count: np.ndarray, controls: tuple, ego: tuple, traffic: tuple, trig: tuple, timers: tuple,
                    a: tuple, lead: tuple, lanes: tuple, ring: tuple, hook: tuple, band: tuple, stim: tuple, hits: tuple,
                    stop: tuple) -> tuple[int, int, int]:  # fmt: skip
    """`platoon_substeps` for the envs lo..hi-1, each physics step in the order of
    `BatchCore._physics_step` and `PlatoonBatch`'s pass after it: the step clock, the ego car
    (`ego.step`), its world's traffic (`FlatTraffic.step`), the trigger contact
    (`TriggerBatch.touching`) unless paused, the running reaction timer (`TimerBatch.update`)
    unless paused, then `after_one`. An env whose traffic needs Python parks with
    `stage` TRAFFIC (the traffic code in the traffic tuple's `codes`), one that touches a trigger with a trigger
    not locked parks with FIRE (`contact` its volume); a `resume` call steps only the parked
    envs, from where they parked.

    The tuples: `controls` (steer, gas, brake); `ego` the car's constants (car table, engine
    on, suppress cruise off, minimum speed) and arrays (x, z, yaw, u, v, r, gear, rpm, prev_v,
    fuel used, fuel left, steer_in, gas_in, brake_in, cruise on, cruise target, cruise
    integral); `traffic` `motion.step_rows`' arguments (the world of env e: rows e*c..e*c+c-1;
    its ego position in `ego3`), `codes`; `trig` (paused, box shift, half width, half length,
    volumes, their triggers, locks, the search hints, contact); `timers` (any timer spec, then
    `kernels.update_timers`' arrays); `ring` (block a, block b, row of step 0, ring steps, with
    pedals, recording: trace row k goes to row `row0 + k` of the two blocks); the others
    `after_one`'s (its `a` with t, sin_y, cos_y). Compiled without reference counting
    (`jit.borrowing_kernel`: the inlined helpers take arrays at every physics step, whose
    counts would otherwise be updated atomically each time); it allocates nothing."""
    steer, gas, brake = controls
    car, engine_on, suppress_cruise_off, min_speed, x, z, yaw, u, v, r, gear, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, \
        brake_in, cruise_on, cruise_target, cruise_int = ego  # fmt: skip
    f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, ego3, work, flags, stop_mask, brake_out, turn_out, net, quiet, c, rows, \
        codes = traffic  # fmt: skip
    paused, shift, hx, hz, vols, vol_triggers, locks, near, contact = trig
    has_timers, active, spec, start_t, start_x, start_z, tlim, dlim, peak, hold_since, braked, start_lane, table, bands, done, \
        done_t = timers  # fmt: skip
    t, sin_y, cos_y = a[7], a[8], a[9]
    block_a, block_b, row0, ring_steps, pedals, rec = ring
    block = block_a.shape[0] * PLATOON_TRACE_GROUP  # rows of a block (grouped: (BLOCK / GROUP, n, GROUP, column))
    parked, ran, changed = 0, k_from, 0
    for e in range(lo, hi):
        if not resume:
            park[e], contact[e] = -1, -1
        if not live[e] or (resume and park[e] < 0):
            continue
        k, at = (park[e], stage[e]) if resume else (k_from, STEP)
        park[e], contact[e] = -1, -1
        angle = steer[e] * MAX_WHEEL_ANGLE_RAD
        cos_a, sin_a = math.cos(angle), math.sin(angle)
        wc = wheel_constants(car, dt, cos_a, sin_a)  # (the steering is held for the policy step: once per env and call)
        # the trigger box's z at the last search, how far from it no volume can be reached (but one
        # whose triggers are all locked), and until when those stay locked
        anchor, clear, wake = 0.0, -math.inf, math.inf
        if rec and e + 1 < hi:  # (the next env's trace rows of this policy step, fetched while this env steps)
            last = block_a.shape[3] - 1
            for ahead in range(row0 + k, min(row0 + k_to, block)):
                prefetch_write(block_a, (ahead // PLATOON_TRACE_GROUP, e + 1, ahead % PLATOON_TRACE_GROUP, 0))
                prefetch_write(block_a, (ahead // PLATOON_TRACE_GROUP, e + 1, ahead % PLATOON_TRACE_GROUP, last))
        while k < k_to:
            if at == STEP:
                sc = step_count[e] + 1
                step_count[e], t[e] = sc, sc * dt
                u0 = u[e]
                steer_in[e] = steer[e]
                x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e], fuel_used[e], fuel_left[e], cruise_on[e], cruise_int[e], \
                    gas_in[e], brake_in[e], sin_y[e], cos_y[e] = ego_step_wheels(
                        car, wc, engine_on, suppress_cruise_off, min_speed, dt, x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e],
                        prev_v[e], fuel_used[e], fuel_left[e], cruise_on[e], cruise_target[e], cruise_int[e], cos_a, sin_a, gas[e],
                        brake[e],
                    )  # fmt: skip
                prev_v[e] = u0  # (sin_y, cos_y: `math.sin` and `math.cos` of the new yaw, from the body step)
                ego3[0, e], ego3[1, e] = x[e], z[e]
                code, _ = step_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t, ego3, dt, work, flags, stop_mask,
                                    brake_out, turn_out, net, quiet, c, rows, e * c, (e + 1) * c)  # fmt: skip
                codes[e] = code
                if code != 0 and code != NOTHING_LIVE:
                    park[e], stage[e] = k, TRAFFIC  # (Python finishes the traffic step)
                    break
                at = TRAFFIC
            if at == TRAFFIC and not paused[e]:
                bx, bz = x[e] - shift * sin_y[e], z[e] - shift * cos_y[e]  # (`kernels.box_centre`)
                j, anchor, clear, wake = gated_contact(e, bx, bz, yaw[e], t[e], hx, hz, vols, vol_triggers, locks, near, anchor, clear,
                                                       wake)  # fmt: skip
                if j >= 0:
                    park[e], stage[e], contact[e] = k, FIRE, j  # (Python fires them)
                    break
            at = STEP
            if has_timers and active[e] and not paused[e]:
                how, peak[e], braked[e], hold_since[e] = timer_step(
                    table, bands, spec[e], start_t[e], start_x[e], start_z[e], tlim[e], dlim[e], peak[e], hold_since[e], braked[e],
                    start_lane[e], t[e], x[e], z[e], u[e], steer_in[e], brake_in[e],
                )  # fmt: skip
                if how:
                    active[e], done[e], done_t[e] = False, how, t[e]
            row = row0 + k
            out, at_row = (block_a, row) if row < block else (block_b, row - block)
            changed += after_one(e, k, live, a, lead, lanes, (out, at_row, ring_steps, pedals, rec), hook, band, stim, hits, stop)
            k += 1
            if not live[e]:
                break
        if park[e] >= 0:
            parked += 1
        elif k > ran:
            ran = k
    return parked, ran, changed


@inline
def gated_contact(e: int, bx: float, bz: float, yaw: float, t: float, hx: float, hz: float, vols: np.ndarray, vol_triggers: np.ndarray,
                  locks: np.ndarray, near: np.ndarray, anchor: float, clear: float,
                  wake: float) -> tuple[int, float, float, float]:  # fmt: skip
    """The volume (row of `vols`) whose armed trigger env e's trigger box (centre bx, bz,
    heading yaw, half sizes hx, hz) touches at time t, or -1: what `nearest_volume` and
    `volume_fires` answer, searched only when the answer may have changed. (anchor, clear,
    wake) carry what the last search learnt from one physics step to the next (start a
    policy step with 0, -inf, inf): no volume but a locked one is within reach while the box
    stays within `clear` of z = `anchor`, and the locked one stays locked before `wake`.
    Returns the volume and the new (anchor, clear, wake)."""
    if abs(bz - anchor) < clear - CLEAR_MARGIN_M and t < wake:
        return -1, anchor, clear, wake
    anchor, clear, wake = bz, _clear_of_volumes(bz, vols, -1), math.inf
    j, near[e] = nearest_volume(bx, bz, vols, near[e])
    if j < 0:
        return -1, anchor, clear, wake
    armed = armed_from(e, j, vol_triggers, locks)
    if not t >= armed:  # (its triggers locked, as while the car stays in it: skip it until then)
        return -1, anchor, _clear_of_volumes(bz, vols, j), armed
    return (j if volume_touches(j, bx, bz, yaw, hx, hz, vols) else -1), anchor, clear, wake


@inline
def _clear_of_volumes(bz: float, vols: np.ndarray, skip: int) -> float:
    """How far (along z) a trigger box centred at z = bz may move before any volume but
    `skip` (-1: none) can be within reach of it: min over those volumes of |cz - bz| - reach
    (-inf where one is NaN). While the box stays closer than that to bz, every such volume
    is at least its reach away along z, so `nearest_volume` finds none of them within reach:
    `platoon_substeps` searches again only once the box leaves that range (or, when it
    skipped a volume whose triggers were all locked, once one of them is armed again)."""
    clear = math.inf
    for v in range(vols.shape[0]):
        d = abs(vols[v, V_CZ] - bz) - vols[v, V_REACH]
        if v != skip and not d >= clear:
            clear = d if d == d else -math.inf
    return clear


def traffic_events(tr: Any, w: int, code: int, dt: float, t: np.ndarray, ego3: np.ndarray) -> None:
    """`TrafficManager._step_with_events` for world w of the flat traffic `tr` (`FlatTraffic`),
    whose `motion.step_rows` stopped with `code` for Python: the waits that are over, the legs
    that ended (the single env's `LegLogic`), then the second kernel (`drive`). The kernels
    run on copies of the world's columns (`_world_columns`), written back after each."""
    st, c = tr.st, tr.c
    lo, hi = w * c, (w + 1) * c
    pos, flags = st.pos[lo:hi], tr.flags[lo:hi]
    sp = _world_columns(tr.sp_packed, lo, hi)
    rows = np.ones(c, dtype=bool)
    pf, pp, pi = tr.paths.arrays()
    legs = tr.legs
    legs.t_s = float(t[w])
    if code == WAITS_OVER:
        for k in np.flatnonzero(flags & WAIT_OVER).tolist():
            legs._finish_wait(lo + k)
        pf, pp, pi = tr.paths.arrays()
        f, i, b, work = (_world_columns(x, lo, hi) for x in (st.f, st.i, st.b, tr.work))
        code = advance_carrots(f, i, b, pos, sp, pf, pp, pi, c, rows, t[w : w + 1], dt, work, flags)
        st.f[:, lo:hi], st.i[:, lo:hi], st.b[:, lo:hi], tr.work[:, lo:hi] = f, i, b, work
    if code > 0:
        for k in np.flatnonzero(flags & ARRIVED).tolist():
            legs._arrive(lo + k)
        pf, pp, pi = tr.paths.arrays()
    if code != NOTHING_LIVE:
        f, i, b, work = (_world_columns(x, lo, hi) for x in (st.f, st.i, st.b, tr.work))
        drive(f, i, b, pos, st.end_xz[lo:hi], st.light_xz[lo:hi], st.ext_cmd[lo:hi], sp, pf, pp, pi, c, rows, ego3[:, w : w + 1], dt, work,
              flags, code > 0, tr.no_lights)  # fmt: skip
        st.f[:, lo:hi], st.i[:, lo:hi], st.b[:, lo:hi], tr.work[:, lo:hi] = f, i, b, work


def _world_columns(a: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """A copy of columns lo..hi-1 of `a` (a car-major array, `FlatTraffic(car_major=True)`),
    strided as the same slice of a row-major array would be (numba's layout 'A'), so that the
    kernels called on it are those compiled for the row-major batches, not a new compile."""
    out = np.empty((a.shape[0], hi - lo + 1), dtype=a.dtype)[:, : hi - lo]
    out[...] = a[:, lo:hi]
    return out
