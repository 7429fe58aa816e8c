"""The autoresets of the brake and platoon test batches as one compiled call.

Why: `BatchCore.reset_rows` and `PlatoonBatch._reset_task` reset the envs of a step with
some forty numpy fancy-index assignments (each a Python call and a temporary), a Python
loop over the envs for their generators and lists, the traffic cars' rows
(`MotionState.assign_rows`) and the first trace row's measures (`lead_rows`,
`record_lanes`): at 32,768 envs on one thread about 0.3 us per env-step, most of the step's
Python. Here one loop over the envs reset writes the same values (the single env's reset:
`EgoCar.reset`, the triggers, the reaction timers, the counters, the traffic as the
template's reset left it, the stimulus slots, the lead car measures and lane measures of the
first trace row); Python keeps only the rare per-env lists (stimuli, timer results, stimulus
generators) and the trace ring's reset row when metrics are recorded.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..jit import borrowing_kernel, parallel_kernel
from .kernels import chunk_count, lane_measures
from .platoon_step import _NO_WORK, _lead_one


@parallel_kernel
def reset_envs(idx: np.ndarray, pose: tuple, initial: tuple, ego: tuple, gear: np.ndarray, cruise_on: np.ndarray, trig: tuple,
               timer: tuple, held: np.ndarray, counters: tuple, measures: tuple, road: tuple, lanes: tuple, traffic: tuple,
               traffic0: tuple, hitting: np.ndarray, task: tuple, revealed: np.ndarray, lead: tuple,
               draws: np.ndarray) -> None:  # fmt: skip
    """`reset_range` of all the envs `idx` (ascending), chunks of them on numba's threads (a
    reset writes scattered rows: ~2 us per env on one core, most of it waiting for memory)."""
    m = len(idx)
    chunks = chunk_count(m)
    for k in prange(chunks):
        reset_range(k * m // chunks, (k + 1) * m // chunks, idx, pose, initial, ego, gear, cruise_on, trig, timer, held, counters,
                    measures, road, lanes, traffic, traffic0, hitting, task, revealed, lead, draws)  # fmt: skip


@borrowing_kernel
def reset_range(lo: int, hi: int, idx: np.ndarray, pose: tuple, initial: tuple, ego: tuple, gear: np.ndarray, cruise_on: np.ndarray,
                trig: tuple, timer: tuple, held: np.ndarray, counters: tuple, measures: tuple, road: tuple, lanes: tuple, traffic: tuple,
                traffic0: tuple, hitting: np.ndarray, task: tuple, revealed: np.ndarray, lead: tuple,
                draws: np.ndarray) -> None:  # fmt: skip
    """`BatchCore.reset_rows` with seed None and `PlatoonBatch._reset_task` (`BrakeBatch`'s:
    `revealed`) for the envs idx[lo:hi], less their Python lists and the trace ring: the world
    seed counted in `draws` (drawn when the env's generator is next read, `BatchCore.rng`),
    the car at its start pose (`ego.reset_rows`), triggers, timers' arrays, buttons held,
    counters, the lane measures zeroed, `last_s`, the world's traffic rows copied from the
    template's (`traffic0`: the same packed arrays, one world; `FlatTraffic.reset_rows`), no
    contact, no stimulus, then the first trace row's lead car measures (`lead_rows`) and lane
    measures (`record_lanes`, first row).

    The tuples: `pose` (x, y, z, yaw); `initial` (speed, gear, rpm, fuel); `ego` the float
    arrays (x, y, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in,
    brake_in, cruise_target, cruise_int); `trig` (locks, counts, paused, started, started_at);
    `timer` (active, kind, n_results); `counters` (step_count, collisions, collisions_seen,
    reaction cursor, new_collisions); `measures` (t, progress, the lane measures' n, mean,
    m2, area, dist, last_s); `road` (sign, origin z); `lanes` (centres, half width, keep_m,
    lat, lane, offset, prev_x, prev_z); `traffic` and `traffic0` (f, i, b, pos, end_xz,
    light_xz, ext_cmd, stuck_hist; cars per world); `task` (on, n_stimuli, n_brake_stimuli,
    reward_acc, seen, dirty); `lead` `_lead_one`'s arrays after the ego's (pos, yaw, speed,
    enabled, half_len, c, ego_length, lead_j, lead_gap, lead_v, headway, ttc) and the trace
    columns gap_m, lead_speed_mps."""
    x, y, z, yaw, u, v, r, rpm, prev_v, fuel_used, fuel_left, steer_in, gas_in, brake_in, cruise_target, cruise_int = ego
    px, py, pz, pyaw = pose
    speed, gear0, rpm0, fuel0 = initial
    locks, counts, paused, started, started_at = trig
    active, kind, n_results = timer
    step_count, collisions, collisions_seen, cursor, new_collisions = counters
    t, progress, rl_n, rl_mean, rl_m2, rl_area, rl_dist, last_s = measures
    sign, origin_z = road
    centres, half_width, keep_m, lat, lane, offset, prev_x, prev_z = lanes
    f, i, b, pos, end_xz, light_xz, ext_cmd, stuck_hist, c = traffic
    f0, i0, b0, pos0, end_xz0, light_xz0, ext_cmd0, stuck_hist0 = traffic0
    on, n_stimuli, n_brake_stimuli, reward_acc, seen, dirty = task
    l_pos, l_yaw, l_speed, l_enabled, half_len, lc, ego_length, lead_j, lead_gap, lead_v, headway, ttc, gap_m, lead_speed = lead
    for q in range(lo, hi):
        e = idx[q]
        draws[e] += 1
        x[e], y[e], z[e], yaw[e] = px, py, pz, pyaw
        u[e], v[e], r[e] = speed, 0.0, 0.0
        gear[e], rpm[e], prev_v[e] = gear0, rpm0, speed
        fuel_used[e], fuel_left[e] = 0.0, fuel0
        steer_in[e], gas_in[e], brake_in[e] = 0.0, 0.0, 0.0
        cruise_on[e], cruise_target[e], cruise_int[e] = speed > 0.0, speed, 0.0
        for j in range(locks.shape[1]):
            locks[e, j] = -math.inf
        for j in range(counts.shape[1]):
            counts[e, j] = 0
        paused[e], started[e], started_at[e] = False, False, 0.0
        active[e], kind[e], n_results[e] = False, -1, 0
        for j in range(held.shape[1]):
            held[e, j] = False
        step_count[e], collisions[e], collisions_seen[e], cursor[e], new_collisions[e] = 0, 0, 0, 0, 0
        t[e], progress[e], rl_area[e], rl_dist[e] = 0.0, 0.0, 0.0, 0.0
        last_s[e] = -sign * (z[e] - origin_z)
        for k in range(c):
            row = e * c + k
            for j in range(f.shape[0]):
                f[j, row] = f0[j, k]
            for j in range(i.shape[0]):
                i[j, row] = i0[j, k]
            for j in range(b.shape[0]):
                b[j, row] = b0[j, k]
            for j in range(pos.shape[1]):
                pos[row, j] = pos0[k, j]
            end_xz[row, 0], end_xz[row, 1] = end_xz0[k, 0], end_xz0[k, 1]
            light_xz[row, 0], light_xz[row, 1] = light_xz0[k, 0], light_xz0[k, 1]
            for j in range(ext_cmd.shape[1]):
                ext_cmd[row, j] = ext_cmd0[k, j]
            for j in range(stuck_hist.shape[1]):
                stuck_hist[row, j, 0], stuck_hist[row, j, 1] = stuck_hist0[k, j, 0], stuck_hist0[k, j, 1]
            hitting[row] = False
        for j in range(on.shape[1]):
            on[e, j] = False
        n_stimuli[e], n_brake_stimuli[e], reward_acc[e], seen[e], dirty[e] = 0, 0, 0.0, 0, False
        for j in range(revealed.shape[1]):
            revealed[e, j] = False
        _lead_one(e, x, z, math.sin(yaw[e]), math.cos(yaw[e]), u, l_pos, l_yaw, l_speed, l_enabled, half_len, lc, ego_length, lead_j,
                  lead_gap, lead_v, headway, ttc, _NO_WORK)  # fmt: skip
        fin = lead_j[e] >= 0 and math.isfinite(lead_gap[e])
        gap_m[e] = lead_gap[e] if fin else math.inf
        lead_speed[e] = lead_v[e] if fin else math.nan
        lat[e], lane[e], offset[e], rl_n[e], rl_mean[e], rl_m2[e], rl_dist[e], rl_area[e] = lane_measures(
            x[e], z[e], True, sign, centres, half_width, keep_m, offset[e], 0.0, 0.0, 0.0, True, prev_x[e], prev_z[e], 0.0, 0.0
        )
        prev_x[e], prev_z[e] = x[e], z[e]
