"""The physics steps of one Lane Change Test policy step, for all envs, as one compiled call.

Why: `BatchCore._physics_steps` runs each physics step as a handful of kernels with numpy
and Python between them (six times per policy step). That Python holds the GIL, so shards
stepped in threads mostly waited for each other. Here one kernel runs the whole loop (ego
car, trigger contacts, reaction timers, lane measures, trace rows, the LCT's path measures,
early stop) with the same per-car functions as those kernels (`vector.ego.ego_step`,
`kernels.*`, `lct.lct_measure`), so the results are the same floats. It returns to Python
only for the cars that touch a trigger box (its actions are Python), which it then finishes
in a second call; reaction timers that end are scored by Python afterwards.
"""

from __future__ import annotations

import math

import numpy as np

from ..sim.jit import inline, kernel
from ..sim.vehicle import MAX_WHEEL_ANGLE_RAD
from .ego import ego_step
from .kernels import lane_measures, nearest_volume, timer_step, volume_fires


@kernel
def lct_substeps(resume: bool, repeat: int, dt: float, live: np.ndarray, park: np.ndarray, step_count: np.ndarray, t: np.ndarray,
                 paused: np.ndarray, car: np.ndarray, engine_on: bool, suppress_cruise_off: bool, min_speed: float, ego: tuple,
                 gear: np.ndarray, cruise_on: np.ndarray, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray, shift: float, hx: float,
                 hz: float, vols: np.ndarray, vol_triggers: np.ndarray, locks: np.ndarray, near: np.ndarray, contact: np.ndarray,
                 timers: bool, active: np.ndarray, armed: np.ndarray, spec: np.ndarray, timer_f: tuple, braked: np.ndarray,
                 start_lane: np.ndarray, timer_table: np.ndarray, bands: np.ndarray, done: np.ndarray, done_t: np.ndarray, sign: float,
                 centres: np.ndarray, half_width: float, keep_m: float, lat: np.ndarray, lane: np.ndarray, offset: np.ndarray,
                 sdlp: tuple, ring: bool, block_a: np.ndarray, block_b: np.ndarray, row0: int, ring_steps: np.ndarray, start_z: float,
                 norm: np.ndarray, d0: float, norm_step: float, scale: float, has_prev: np.ndarray, path: tuple, off_road: float,
                 steering: tuple) -> tuple[int, int]:  # fmt: skip
    """The physics steps of the envs `live` (cleared for those that stop early), car by car:
    each car's state stays in registers for its steps.

    A car that touches a trigger box in its physics step k is parked there (`park[e] = k`,
    `contact[e]` the volume; -1 otherwise) for Python to fire the triggers; a call with
    `resume` then goes on with the parked cars only, after their contact test. Returns (cars
    parked, the most physics steps a finished car ran). The tuples hold float arrays: `ego`
    (x, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in,
    cruise_target, cruise_int), `timer_f` (start_t, start_x, start_z, peak, hold_since),
    `sdlp` (n, mean, m2), `path` (prev_d, prev_dev, area, reward), `steering` (each car's
    steering angle, its cosine and sine: the steering is held for the policy step); trace
    rows are (x, z, u, steer_in).
    """
    x, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in, cruise_target, cruise_int = ego
    timer_t, timer_x, timer_z, peak, hold_since = timer_f  # (not start_z: the LCT's start)
    sd_n, sd_mean, sd_m2 = sdlp
    prev_d, prev_dev, area, reward = path
    angle, cos_a, sin_a = steering
    block = block_a.shape[1]
    parked, ran = 0, 0
    for e in range(len(live)):
        if not resume:
            contact[e] = -1
        if not live[e] or (resume and park[e] < 0):
            continue
        k, moved = (park[e], True) if resume else (0, False)
        park[e], contact[e] = -1, -1
        if not resume:
            angle[e] = steer[e] * MAX_WHEEL_ANGLE_RAD
            cos_a[e], sin_a[e] = math.cos(angle[e]), math.sin(angle[e])
        # the car's state, kept in locals until it stops, parks or ends the policy step
        xe, ze, yawe, ue, ve, re, geare, rpme, pv, fu, fl = x[e], z[e], yaw[e], u[e], v[e], r[e], gear[e], rpm[e], prev_v[e], \
            fuel_used[e], fuel_left[e]  # fmt: skip
        si, gi, bi, con, cint, sc, te = steer_in[e], gas_in[e], brake_in[e], cruise_on[e], cruise_int[e], step_count[e], t[e]
        la, ln, off, sn, sm, sm2, nr, rs = lat[e], lane[e], offset[e], sd_n[e], sd_mean[e], sd_m2[e], near[e], ring_steps[e]
        pd, pdev, ar, rw, hp = prev_d[e], prev_dev[e], area[e], reward[e], has_prev[e]
        while k < repeat:
            if not moved:
                sc += 1
                te = sc * dt
                u0, si = ue, steer[e]
                xe, ze, yawe, ue, ve, re, geare, rpme, fu, fl, con, cint, gi, bi, sy, cy = ego_step(
                    car, engine_on, suppress_cruise_off, min_speed, dt, xe, ze, yawe, ue, ve, re, geare, rpme, pv, fu, fl, con,
                    cruise_target[e], cint, angle[e], cos_a[e], sin_a[e], gas[e], brake[e],
                )  # fmt: skip
                pv = u0
                if not paused[e]:
                    bx, bz = xe - shift * sy, ze - shift * cy  # (`kernels.box_centre`)
                    j, nr = nearest_volume(bx, bz, vols, nr)
                    if j >= 0 and volume_fires(e, j, bx, bz, yawe, hx, hz, vols, vol_triggers, te, locks):
                        park[e], contact[e] = k, j
                        break
            moved = False
            if timers and active[e] and not paused[e]:
                how, expired, peak[e], braked[e], hold_since[e] = timer_step(
                    timer_table, bands, spec[e], armed[e], timer_t[e], timer_x[e], timer_z[e], peak[e], hold_since[e], braked[e],
                    start_lane[e], te, xe, ze, ue, si, bi,
                )  # fmt: skip
                if expired:
                    active[e] = False
                if how:
                    active[e], done[e], done_t[e] = False, how, te
            la, ln, off, sn, sm, sm2, _, _ = lane_measures(
                xe, ze, False, sign, centres, half_width, keep_m, off, sn, sm, sm2, False, 0.0, 0.0, 0.0, 0.0
            )
            if ring:
                row = row0 + k
                out, i = (block_a, row) if row < block else (block_b, row - block)
                out[0, i, e], out[1, i, e], out[2, i, e], out[3, i, e] = xe, ze, ue, si
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
