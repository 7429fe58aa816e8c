"""Per physics step measures of the platoon and brake test batches as compiled passes.

Why: `PlatoonBatch` computed the lead car (`perception.lead_vehicle`), headway and TTC, the
lead and follower band control (`PlatoonCore._band_control`) and the band deviations and
reward shares with a dozen numpy expressions per physics step, each allocating N- or
NxC-sized temporaries. Here each is one pass over the envs, chunked like `lct_step`
(`parallel` runs the chunks on numba's threads; the `_range` twins run serially, for thread
shards and batches of one chunk). The formulas are the numpy ones, operand for operand, so
the floats are the same (`_max`/`_min` keep numpy's NaN rules).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..jit import inline, kernel, parallel_kernel
from .kernels import chunk_count


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
def _lead_range(lo: int, hi: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray, car_yaw: np.ndarray,
                speed: np.ndarray, enabled: np.ndarray, half_len: np.ndarray, c: int, ego_length: float, lead_j: np.ndarray,
                lead_gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray) -> None:  # fmt: skip
    """For the envs lo..hi-1: the nearest enabled car ahead within 1.5 m of the ego's axis and
    200 m (`perception.lead_vehicle`; -1: none, its gap and speed then those of car 0 as
    numpy's argmin left them), the gap between the bumpers (m), its speed along the ego's
    heading, the time headway (gap + its length over the ego's speed) and the TTC (inf where
    not defined)."""
    for e in range(lo, hi):
        fx, fz = -math.sin(yaw[e]), -math.cos(yaw[e])
        lx, lz = -math.cos(yaw[e]), math.sin(yaw[e])
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
        v = speed[r] * (-math.sin(vyaw) * fx - math.cos(vyaw) * fz)
        lead_j[e], lead_gap[e], lead_v[e] = j if found else -1, gap, v
        ok = found and math.isfinite(gap)
        headway[e] = (gap + 2.0 * hl) / u[e] if ok and u[e] > 0.0 else math.inf
        closing = u[e] - v
        ttc[e] = _max(gap, 0.0) / closing if ok and closing > 0.0 else math.inf


@parallel_kernel
def platoon_hook(rows: np.ndarray, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray,
                 ov_speed: np.ndarray, ov_decel: np.ndarray, c: int, on: np.ndarray, kind: np.ndarray, car: np.ndarray,
                 lead_i: int, follow_i: int, with_follower: bool, band: tuple, offset: np.ndarray, ttc: np.ndarray,
                 lon_dev: np.ndarray, reward_acc: np.ndarray) -> None:  # fmt: skip
    """`PlatoonBatch._on_physics_step` but its stimuli, for every env (see `_hook_range`)."""
    n = len(x)
    chunks = chunk_count(n)
    for k in prange(chunks):
        _hook_range(k * n // chunks, (k + 1) * n // chunks, rows, x, z, yaw, u, pos, ov_speed, ov_decel, c, on, kind, car, lead_i,
                    follow_i, with_follower, band, offset, ttc, lon_dev, reward_acc)  # fmt: skip


@kernel
def _hook_range(lo: int, hi: int, rows: np.ndarray, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray, pos: np.ndarray,
                ov_speed: np.ndarray, ov_decel: np.ndarray, c: int, on: np.ndarray, kind: np.ndarray, car: np.ndarray, lead_i: int,
                follow_i: int, with_follower: bool, band: tuple, offset: np.ndarray, ttc: np.ndarray, lon_dev: np.ndarray,
                reward_acc: np.ndarray) -> None:  # fmt: skip
    """For the envs lo..hi-1 that step (`rows`): the lead car's speed held in its distance band
    and the follower's at the middle of its band unless a speed stimulus drives that car
    (`PlatoonCore._band_control`), then the longitudinal and lateral band deviations and the
    step's share of the deviation and TTC penalties (`ThreeVehiclePlatoonEnv._on_physics_step`).
    `band`: nominal speed, band gain, lead band min, max, follower gain, catch-up speed,
    follower band min, max, longitudinal band lower, upper, lateral band lower, upper,
    deviation cap, penalty per m, TTC weight, TTC threshold, action repeat, speed-stimulus
    kind (the first kind >= it drives a car's speed)."""
    (nominal, gain, lead_min, lead_max, f_gain, catch_up, f_min, f_max, lon_lo, lon_hi, lat_lo, lat_hi, cap, per_m, ttc_w, ttc_thr,
     repeat, speed_kind) = band  # fmt: skip
    slots = on.shape[1]
    for e in range(lo, hi):
        if not rows[e]:
            continue
        busy, busy_f = False, False
        for s in range(slots):
            if on[e, s] and kind[e, s] >= speed_kind:
                busy = busy or car[e, s] == lead_i
                busy_f = busy_f or car[e, s] == follow_i
        sy, cy = math.sin(yaw[e]), math.cos(yaw[e])
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
