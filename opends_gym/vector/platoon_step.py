"""Per physics step measures of the platoon and brake test batches as compiled passes.

Why: `PlatoonBatch` computed the lead car (`perception.lead_vehicle`), headway and TTC, the
lead and follower band control (`PlatoonCore._band_control`) and the band deviations and
reward shares, the stimuli (`setTVPTStimulus`: reactions, results, ends) and the early stop
with a few dozen numpy expressions per physics step, each allocating N- or NxC-sized
temporaries. Here all that follows a physics step's ego, traffic, trigger and timer part is
one pass over the envs (`platoon_after`), chunked like `lct_step` (`parallel` runs the
chunks on numba's threads; the `_range` twins run serially, for thread shards and batches
of one chunk). The formulas are the numpy ones, operand for operand, so the floats are the
same (`_max`/`_min` keep numpy's NaN rules).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..jit import inline, kernel, parallel_kernel, python_buffers, whole_batch
from ..sim.geometry2d import boxes_overlap
from ..sim.traffic.motion import N_WORK, W_COS, W_SIN, W_TRIG_OK, W_TRIG_YAW, sin_cos
from .kernels import chunk_count, lane_measures
from .trace import PLATOON_TRACE_GROUP

_NO_WORK = np.zeros((N_WORK, 0))  # (no traffic work rows: `_lead_one` takes the lead car's sine and cosine itself)


@inline
def _max(a: float, b: float) -> float:
    """`np.maximum` of two floats (NaN wins, a on ties)."""
    return a if (a >= b or a != a) else b


@inline
def _min(a: float, b: float) -> float:
    """`np.minimum` of two floats (NaN wins, a on ties)."""
    return a if (a <= b or a != a) else b


@parallel_kernel
def lead_measures(x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray, car_yaw: np.ndarray,
                  speed: np.ndarray, enabled: np.ndarray, half_len: np.ndarray, c: int, ego_length: float, lead_j: np.ndarray,
                  lead_gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray) -> None:  # fmt: skip
    """`FlatTraffic.lead` and `PlatoonBatch`'s headway and TTC of every env (see `_lead_range`)."""
    n = len(x)
    chunks = chunk_count(n)
    for k in prange(chunks):
        _lead_range(k * n // chunks, (k + 1) * n // chunks, x, z, yaw, u, pos, car_yaw, speed, enabled, half_len, c, ego_length,
                    lead_j, lead_gap, lead_v, headway, ttc)  # fmt: skip


@kernel
def lead_rows(idx: np.ndarray, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray, car_yaw: np.ndarray,
              speed: np.ndarray, enabled: np.ndarray, half_len: np.ndarray, c: int, ego_length: float, lead_j: np.ndarray,
              lead_gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray, gap_m: np.ndarray,
              lead_speed: np.ndarray) -> None:  # fmt: skip
    """`_lead_range` of the envs `idx` (those reset), with their trace columns `gap_m` and
    `lead_speed_mps` (inf and NaN without a lead car)."""
    for e in idx:
        _lead_one(e, x, z, math.sin(yaw[e]), math.cos(yaw[e]), u, pos, car_yaw, speed, enabled, half_len, c, ego_length, lead_j, lead_gap,
                  lead_v, headway, ttc, _NO_WORK)  # fmt: skip
        fin = lead_j[e] >= 0 and math.isfinite(lead_gap[e])
        gap_m[e] = lead_gap[e] if fin else math.inf
        lead_speed[e] = lead_v[e] if fin else math.nan


@kernel
def _sin_cos(lo: int, hi: int, yaw: np.ndarray, sin_y: np.ndarray, cos_y: np.ndarray) -> None:
    """The sine and cosine of the yaws of the envs lo..hi-1 (`math`'s: numpy's may differ in the last bit)."""
    for e in range(lo, hi):
        sin_y[e], cos_y[e] = math.sin(yaw[e]), math.cos(yaw[e])


@whole_batch
@python_buffers
@kernel
def _lead_range(lo: int, hi: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray, car_yaw: np.ndarray,
                speed: np.ndarray, enabled: np.ndarray, half_len: np.ndarray, c: int, ego_length: float, lead_j: np.ndarray,
                lead_gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray) -> None:  # fmt: skip
    """For the envs lo..hi-1: the nearest enabled car ahead within 1.5 m of the ego's axis and
    200 m (`perception.lead_vehicle`; -1: none, its gap and speed then those of car 0 as
    numpy's argmin left them), the gap between the bumpers (m), its speed along the ego's
    heading, the time headway (gap + its length over the ego's speed) and the TTC (inf where
    not defined)."""
    for e in range(lo, hi):
        _lead_one(e, x, z, math.sin(yaw[e]), math.cos(yaw[e]), u, pos, car_yaw, speed, enabled, half_len, c, ego_length, lead_j, lead_gap,
                  lead_v, headway, ttc, _NO_WORK)  # fmt: skip


@inline
def _lead_one(e: int, x: np.ndarray, z: np.ndarray, sy: float, cy: float, u: np.ndarray, pos: np.ndarray, car_yaw: np.ndarray,
              speed: np.ndarray, enabled: np.ndarray, half_len: np.ndarray, c: int, ego_length: float, lead_j: np.ndarray,
              lead_gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray, work: np.ndarray) -> None:  # fmt: skip
    """`_lead_range` of env e, whose yaw has sine sy and cosine cy; the lead car's sine and
    cosine are those its traffic step kept in `work` (`motion._move`) when they belong to its
    yaw (as `motion._carrot` reuses them), else taken here: the same floats, one `sincos`
    less per physics step."""
    fx, fz = -sy, -cy
    lx, lz = -cy, sy
    best, j, found = math.inf, 0, False
    best_ahead = 0.0
    for i in range(c):
        r = e * c + i
        dx, dz = pos[r, 0] - x[e], pos[r, 2] - z[e]
        ahead = dx * fx + dz * fz
        side = dx * lx + dz * lz
        if enabled[r] and ahead > 0.0 and abs(side) <= 1.5 and ahead < 200.0:
            found = True
            if ahead < best:
                best, j = ahead, i
        if i == 0:
            best_ahead = ahead
    r = e * c + j
    ahead_j = best if found else best_ahead
    hl = half_len[r]
    gap = ahead_j - hl - 0.5 * ego_length
    vyaw = car_yaw[r]
    if r < work.shape[1] and work[W_TRIG_OK, r] != 0.0 and vyaw != 0.0 and work[W_TRIG_YAW, r] == vyaw:
        vs, vc = work[W_SIN, r], work[W_COS, r]
    else:
        vs, vc = sin_cos(vyaw)
    v = speed[r] * (-vs * fx - vc * fz)
    lead_j[e], lead_gap[e], lead_v[e] = j if found else -1, gap, v
    ok = found and math.isfinite(gap)
    headway[e] = (gap + 2.0 * hl) / u[e] if ok and u[e] > 0.0 else math.inf
    closing = u[e] - v
    ttc[e] = _max(gap, 0.0) / closing if ok and closing > 0.0 else math.inf


@inline
def _hook_one(e: int, x: np.ndarray, z: np.ndarray, sy: float, cy: float, u: np.ndarray, pos: np.ndarray, ov_speed: np.ndarray,
              ov_decel: np.ndarray, c: int, on: np.ndarray, kind: np.ndarray, car: np.ndarray, lead_i: int, follow_i: int,
              with_follower: bool, band: tuple, offset: np.ndarray, ttc: np.ndarray, lon_dev: np.ndarray,
              reward_acc: np.ndarray) -> None:  # fmt: skip
    """For env e (its yaw's sine sy and cosine cy; a part of `after_one`): the lead car's speed held in its distance band
    and the follower's at the middle of its band unless a speed stimulus drives that car
    (`PlatoonCore._band_control`), then the longitudinal and lateral band deviations and the
    step's share of the deviation and TTC penalties (`ThreeVehiclePlatoonEnv._on_physics_step`).
    `band`: nominal speed, band gain, lead band min, max, follower gain, catch-up speed,
    follower band min, max, longitudinal band lower, upper, lateral band lower, upper,
    deviation cap, penalty per m, TTC weight, TTC threshold, action repeat, speed-stimulus
    kind (the first kind >= it drives a car's speed)."""
    (nominal, gain, lead_min, lead_max, f_gain, catch_up, f_min, f_max, lon_lo, lon_hi, lat_lo, lat_hi, cap, per_m, ttc_w, ttc_thr,
     repeat, speed_kind) = band  # fmt: skip
    busy, busy_f = False, False
    for s in range(on.shape[1]):
        if on[e, s] and kind[e, s] >= speed_kind:
            busy = busy or car[e, s] == lead_i
            busy_f = busy_f or car[e, s] == follow_i
    r = e * c + lead_i
    gap = (pos[r, 0] - x[e]) * -sy + (pos[r, 2] - z[e]) * -cy  # (`PlatoonBatch._distance_to`)
    if not busy:
        if gap > lead_max:
            ov_speed[r] = _max(0.0, _max(0.0, nominal - gain * (gap - lead_max)))
        elif gap < lead_min:
            ov_speed[r] = _max(0.0, nominal + gain * (lead_min - gap))
        else:
            ov_speed[r] = math.nan
        ov_decel[r] = math.nan
    if with_follower and not busy_f:
        f = e * c + follow_i
        d = (pos[f, 0] - x[e]) * -sy + (pos[f, 2] - z[e]) * -cy
        ft = u[e] + f_gain * (-d - 0.5 * (f_min + f_max))
        ov_speed[f] = _max(0.0, _min(_max(0.0, ft), nominal + catch_up))
        ov_decel[f] = math.nan
    lon = _max(_max(0.0, lon_lo - gap), gap - lon_hi)
    lon_dev[e] = lon
    lat = _max(_max(0.0, lat_lo - offset[e]), offset[e] - lat_hi)
    acc = reward_acc[e] - per_m * _min(lon + lat, cap) / repeat
    if ttc_w > 0.0:
        acc = acc - ttc_w * _max(0.0, 1.0 - ttc[e] / ttc_thr) / repeat
    reward_acc[e] = acc


@inline
def after_one(e: int, k: int, live: np.ndarray, a: tuple, lead: tuple, lanes: tuple, ring: tuple, hook: tuple, band: tuple, stim: tuple,
              hits: tuple, stop: tuple) -> int:  # fmt: skip
    """What follows the ego, traffic, trigger and timer part of physics step k of live env e
    (the platoon and brake batches' `_physics_steps`), in the order of
    `BatchCore._physics_steps`: `_record_row` (`_lead_measures`, `record_lanes` and the trace
    row), `_on_physics_step` (`_hook_one`, the lon_dev column, the stimuli), the contacts with
    traffic cars that begin (`FlatTraffic.new_hits`, counted here: no trigger action or timer
    reads them) and `_stop_early` (`_terminated`: env e stops, `live[e] = False`). Returns
    how many stimuli changed result (flagged in `changed`, 1 missed, 2 reacted, with the
    reaction time in `react` and the hold clock in `held`; the caller clears the flags once
    Python has copied them into its `Stimulus` records).

    The tuples: `a` the ego arrays (x, z, yaw, u, steer_in, gas_in, brake_in, t) and the sine
    and cosine of each yaw (taken after the ego step); `lead` `_lead_one`'s arguments after
    the ego's, `gap_m` and `lead_speed_mps` before its last (the traffic's work rows); `lanes`
    `lane_measures`' constants and arrays;
    `ring` (block: grouped, `TraceRing(grouped=True)`; row, ring steps, with pedals, recording); `hook` `_hook_one`'s arguments
    after the ego's but `band`; `stim` the stimulus slots and constants, `changed`, `react`,
    `held`; `hits` the ego box (shift of its centre, half width, half length), each car's
    reach and half extents and the cars touching the ego; `stop` the early-stop arguments."""
    x, z, yaw, u, steer_in, gas_in, brake_in, t, sin_y, cos_y = a
    pos, car_yaw, speed, enabled, half_len, c, ego_length, lead_j, lead_gap, lead_v, headway, ttc, gap_m, lead_speed, work = lead
    sign, centres, half_width, keep_m, lat, lane, offset, sd_n, sd_mean, sd_m2, prev_x, prev_z, dist, area = lanes
    block, row, steps, pedals, rec = ring
    ov_speed, ov_decel, on, kind, car, lead_i, follow_i, with_follower, lon_dev, reward_acc = hook
    (s_kind, s_onset, s_end, s_target, s_result, s_hold, reset_on, pressed, signal, ov_brake, ov_turn, changed, react, held,
     consts) = stim  # fmt: skip
    brake_threshold, tolerance, sr_hold, max_rt, speed_kind = consts[0], consts[1], consts[2], consts[3], int(consts[4])
    car_shift, ehx, ehz, reach, half, hitting = hits
    off_road, past_lead, terminate_on_collision, paused, collisions, collisions_seen = stop
    sy, cy = sin_y[e], cos_y[e]
    _lead_one(e, x, z, sy, cy, u, pos, car_yaw, speed, enabled, half_len, c, ego_length, lead_j, lead_gap, lead_v, headway, ttc, work)
    fin = lead_j[e] >= 0 and math.isfinite(lead_gap[e])
    gap_m[e] = lead_gap[e] if fin else math.inf
    lead_speed[e] = lead_v[e] if fin else math.nan
    lat[e], lane[e], offset[e], sd_n[e], sd_mean[e], sd_m2[e], dist[e], area[e] = lane_measures(
        x[e], z[e], False, sign, centres, half_width, keep_m, offset[e], sd_n[e], sd_mean[e], sd_m2[e], True, prev_x[e], prev_z[e],
        dist[e], area[e],
    )  # fmt: skip
    prev_x[e], prev_z[e] = x[e], z[e]
    grp, slot = row // PLATOON_TRACE_GROUP, row % PLATOON_TRACE_GROUP  # (a grouped ring: `TraceRing(group=PLATOON_TRACE_GROUP)`)
    if rec:
        block[grp, e, slot, 0], block[grp, e, slot, 1], block[grp, e, slot, 2], block[grp, e, slot, 3] = x[e], z[e], u[e], steer_in[e]
        block[grp, e, slot, 4], block[grp, e, slot, 5], block[grp, e, slot, 6], block[grp, e, slot, 7] = headway[e], ttc[e], gap_m[e], \
            lead_speed[e]  # fmt: skip
        if pedals:
            block[grp, e, slot, 9], block[grp, e, slot, 10] = gas_in[e], brake_in[e]
        steps[e] += 1
    _hook_one(e, x, z, sy, cy, u, pos, ov_speed, ov_decel, c, on, kind, car, lead_i, follow_i, with_follower, band, offset, ttc, lon_dev,
              reward_acc)  # fmt: skip
    if rec:
        block[grp, e, slot, 8] = lon_dev[e]
    count = 0
    te = t[e]
    brake_hit = brake_in[e] >= brake_threshold
    turn_hit = (pressed[e] and k == 0) or signal[e] != 0
    for s in range(on.shape[1]):
        if not on[e, s]:
            continue
        kd = s_kind[e, s]
        is_sr = kd == speed_kind
        ok = is_sr and u[e] <= s_target[e, s] + tolerance
        if is_sr and not ok:
            s_hold[e, s] = math.nan
        if ok and math.isnan(s_hold[e, s]):
            s_hold[e, s] = te
        sr_done = ok and te - s_hold[e, s] >= sr_hold - 1e-9
        if kd == 0 or kd == 4:  # brake light, emergency brake
            reacted = brake_hit
        elif is_sr:
            reacted = sr_done
        else:
            reacted = turn_hit
        new = reacted and s_result[e, s] == 0
        react_s = s_hold[e, s] if is_sr else te
        if new:
            s_result[e, s] = 1 if react_s - s_onset[e, s] <= max_rt + 1e-9 else -2
            changed[e, s], react[e, s], held[e, s] = 2, react_s, s_hold[e, s]
            count += 1
        ends_now = new and reset_on[kd]
        if not ends_now and s_result[e, s] == 0 and te - s_onset[e, s] > max_rt:
            s_result[e, s] = -2
            changed[e, s], held[e, s] = 1, s_hold[e, s]
            count += 1
        if ends_now or (not ends_now and te >= s_end[e, s]):
            r = e * c + car[e, s]
            if kd == 0:
                ov_brake[r] = -1
            if kd == 1 or kd == 2:
                ov_turn[r] = -1
            if kd >= speed_kind:
                ov_speed[r] = math.nan
                ov_decel[r] = math.nan
            on[e, s] = False
    bx, bz = x[e] - car_shift * sy, z[e] - car_shift * cy  # (the box is centred half a wheelbase ahead)
    for i in range(c):
        r = e * c + i
        hit = False
        dx, dz, far = pos[r, 0] - bx, pos[r, 2] - bz, 1.000001 * reach[r]
        # (a car beyond 1.000001 x its reach by the squared distance is beyond it by `np.hypot` too: no hypot for it)
        if enabled[r] and dx * dx + dz * dz < far * far and np.hypot(dx, dz) < reach[r]:
            hit = boxes_overlap(bx, bz, yaw[e], ehx, ehz, pos[r, 0], pos[r, 2], car_yaw[r], half[r, 0], half[r, 1])
        if hit and not hitting[r]:
            collisions[e] += 1
        hitting[r] = hit
    task_end = abs(lat[e]) > off_road
    if past_lead and not task_end:
        r = e * c + lead_i
        task_end = (pos[r, 0] - x[e]) * -sy + (pos[r, 2] - z[e]) * -cy < 0.0
    if paused[e] or task_end or (terminate_on_collision and collisions[e] - collisions_seen[e] > 0):
        live[e] = False
    return count
