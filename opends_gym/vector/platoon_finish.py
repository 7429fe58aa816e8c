"""The end of a brake or platoon test policy step, for all envs, as one compiled call.

Why: after the physics pass (`platoon_pass`), `BatchCore.step_rows`, `PlatoonBatch`'s
reward and `shards.observe` built the step's outputs with a few dozen numpy expressions
(each an N- or NxC-sized temporary) and copied the state into 17 info arrays. Here one pass
over the envs (chunks on numba's threads, as `lct_step.lct_finish`) writes every env's
progress, reward, flags, info values and kinematics observation, with the formulas of
`BatchCore.step_rows` and `BatchCore.info`, `PlatoonBatch._reward` and `_task_terminated`
(`BrakeBatch._reward`'s sign bonus with `brake`), `FlatTraffic.outputs` and `.slots`
(`queries.nearest_slots` on each chunk's worlds) and `PlatoonBatch._stimulus`. The envs
not in `rows` (reset this step) get their fresh state's info, reward 0 and no flags.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..jit import kernel, parallel_kernel
from ..sim.traffic.motion import _outputs_rows
from ..sim.traffic.queries import nearest_slots
from .kernels import chunk_count, ego_features_row
from .platoon_step import _max

# rows of the float and int blocks `platoon_finish` fills (`lct_step`'s: `BatchCore.info`'s keys)
INFO_F = ("sim_time_s", "speed_kmh", "lateral_offset_m", "fuel_used_l", "reaction_result", "reaction_time_s", "mean_deviation_m",
          "sdlp_m", "headway_s", "ttc_s", "reset_time_s", "progress_m")  # fmt: skip
INFO_I = ("lane_index", "collisions", "resets", "new_collisions")


@parallel_kernel
def platoon_finish(outcome: tuple, reward_t: tuple, obs: tuple, stim: tuple, info_f: np.ndarray, info_i: np.ndarray, known: np.ndarray,
                   lanes_known: bool) -> None:  # fmt: skip
    """The end of a policy step of every env (see `_finish_range`), chunks on numba's threads."""
    n = info_f.shape[1]
    chunks = chunk_count(n)
    for j in prange(chunks):
        _finish_range(j * n // chunks, (j + 1) * n // chunks, outcome, reward_t, obs, stim, info_f, info_i, known, lanes_known)


@kernel
def _finish_range(lo: int, hi: int, outcome: tuple, reward_t: tuple, obs: tuple, stim: tuple, info_f: np.ndarray, info_i: np.ndarray,
                  known: np.ndarray, lanes_known: bool) -> None:  # fmt: skip
    """`platoon_finish` for the envs lo..hi-1.

    `outcome`: (rows, road sign, start z, x, z, yaw, u, last_s, progress, collisions,
    collisions seen, new collisions, results logged, reaction cursor, last result, last
    reaction time, SDLP's n and m2, distance and area driven, t, fuel used, offset, lane,
    headway, TTC, lat, paused, terminate on collision, max episode s, reward, terminated,
    truncated); `reward_t`: (reward_acc, progress per m, off-road limit, off-road penalty, end
    past the lead, collision penalty, `bonus` (each env's stimulus results to add, +1 or -1,
    in order) and their number, brake test, sign bonus); `obs`: (out, heading, offset, lat,
    lane, steer_in, yaw rate, vehicle slots K, ego4 scratch (4, n)); `stim`: the traffic
    (pos, yaw, speed, enabled, i, b, brake and turn scratch, cars per env, lead and follower
    index, with follower), the lead measures (lead_j, gap, speed) and the brake test's signs
    (revealed, their z)."""
    rows, sign, origin_z, x, z, yaw, u, last_s, progress, collisions, collisions_seen, new_collisions, n_results, cursor, last_result, \
        last_rt, sd_n, sd_m2, dist, area, t, fuel_used, offset, lane, headway, ttc, lat, paused, terminate_on_collision, max_s, reward, \
        terminated, truncated = outcome  # fmt: skip
    reward_acc, progress_per_m, off_road, off_road_penalty, past_lead, collision_penalty, bonus, n_bonus, brake_test, sign_bonus = reward_t
    out, heading, o_offset, o_lat, o_lane, steer, r_yaw, k_slots, ego4 = obs
    pos, car_yaw, speed, enabled, ti, tb, brake_out, turn_out, c, lead_i, follow_i, with_follower, lead_j, lead_gap, lead_v, revealed, \
        sign_z = stim  # fmt: skip
    width = out.shape[1]
    for e in range(lo, hi):
        # `BatchCore.step_rows` and `info`
        step = rows[e]
        s_now = -sign * (z[e] - origin_z)
        progress[e] = s_now - last_s[e] if step else 0.0
        if step:
            last_s[e] = s_now
        new_collisions[e] = collisions[e] - collisions_seen[e] if step else 0
        collisions_seen[e] = collisions[e]
        fresh = n_results[e] > cursor[e]
        result = last_result[e] if fresh else 0.0
        info_f[4, e], info_f[5, e] = result, (last_rt[e] if fresh else 0.0)
        cursor[e] = n_results[e]
        info_f[0, e], info_f[1, e], info_f[2, e], info_f[3, e] = t[e], u[e] * 3.6, offset[e], fuel_used[e]
        n = sd_n[e]
        info_f[7, e] = math.sqrt(sd_m2[e] / (n if n > 1.0 else 1.0)) if n >= 2 else 0.0
        info_f[6, e] = area[e] / dist[e] if dist[e] > 0 else 0.0
        info_f[8, e], info_f[9, e], info_f[10, e], info_f[11, e] = headway[e], ttc[e], 0.0, progress[e]
        info_i[0, e], info_i[1, e], info_i[2, e], info_i[3, e] = lane[e], collisions[e], 0, new_collisions[e]
        known[e] = lanes_known
        # `PlatoonBatch._task_terminated`, `_reward` (`BrakeBatch._reward`), `BatchCore._terminated`
        sy, cy = math.sin(yaw[e]), math.cos(yaw[e])
        task_end = abs(lat[e]) > off_road
        if past_lead and not task_end:
            lr = e * c + lead_i
            task_end = (pos[lr, 0] - x[e]) * -sy + (pos[lr, 2] - z[e]) * -cy < 0.0
        rw = reward_acc[e] + progress_per_m * _max(0.0, progress[e])
        reward_acc[e] = 0.0
        if task_end:
            rw = rw - off_road_penalty
        for j in range(n_bonus[e]):
            rw = rw + bonus[e, j]
        rw = rw - collision_penalty * float(new_collisions[e])
        if brake_test:
            rw = rw + sign_bonus if result == 1 else rw - sign_bonus if result < 0 else rw
        ended = paused[e] or task_end or (terminate_on_collision and new_collisions[e] > 0)
        reward[e] = rw if step else 0.0
        terminated[e] = ended and step
        truncated[e] = not ended and t[e] >= max_s - 1e-9 and step
        # the observation (`shards.observe`): ego features, vehicle slots, stimulus
        ego_features_row(out, e, u[e], yaw[e], heading, o_offset[e], o_lat[e], o_lane[e], steer[e], r_yaw[e])
        _outputs_rows(ti, tb, brake_out, turn_out, e * c, (e + 1) * c)
        ego4[0, e], ego4[1, e], ego4[2, e], ego4[3, e] = x[e], z[e], yaw[e], u[e]
        col = 7 + 6 * k_slots
        found = lead_j[e] >= 0
        li, fi = e * c + lead_i, e * c + follow_i
        out[e, col] = lead_gap[e] if found else 0.0
        out[e, col + 1] = lead_v[e] - u[e] if found else 0.0
        out[e, col + 2] = 1.0 if brake_out[li] else 0.0
        out[e, col + 3] = float(turn_out[li])
        out[e, col + 4] = -((pos[fi, 0] - x[e]) * -sy + (pos[fi, 2] - z[e]) * -cy) if with_follower else 0.0
        out[e, col + 5] = float(turn_out[fi]) if with_follower else 0.0
        if width > col + 6:  # the brake test's sign: revealed and not yet passed
            seen = False
            for j in range(len(sign_z)):
                seen = seen or (revealed[e, j] and sign_z[j] < z[e])
            out[e, col + 6] = 1.0 if seen else 0.0
    if k_slots > 0:
        nearest_slots(pos[lo * c : hi * c], car_yaw[lo * c : hi * c], speed[lo * c : hi * c], enabled[lo * c : hi * c],
                      brake_out[lo * c : hi * c], turn_out[lo * c : hi * c], c, ego4[:, lo:hi], k_slots, out[lo:hi], 7)  # fmt: skip
