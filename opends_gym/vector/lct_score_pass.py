"""The native LCT batch's ended episodes scored in one parallel compiled pass, into one row each.

Why: on 16 threads the serial scoring of ended episodes (~240 µs of CPU each, ~280 ns per
env-step) capped the batch at ~3.5M env-steps/s. Here each ended episode is scored by one
of numba's threads on its own: its derived trace columns (`trace.score_columns`), the
generic keys (`metrics.episode_scores`), the LCT's SAE J2944 and reversal rates and sign
counts (`metrics.lct_scores.lct_scores`), the lane-change fits and MDEV (`lct_lane_changes`),
the reaction counts (`timers.TimerBatch`'s result arrays) and the sign keys, all into a row
of a wide table whose columns are every key an LCT episode can have (`wide_keys`); the
batch then picks each row's keys (`LctBatch.episodes_table`). Per episode these are the
same calls on the same samples as the batched passes they replace, so the floats are the
same (each kernel sees the episode alone, as rows 0..n-1, which changes no sum: every
reduction runs over one episode's samples).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import prange

from ..jit import kernel, parallel_kernel
from ..metrics import episode_scores
from ..metrics.lct_scores import J2944, lct_lane_changes, lct_scores
from ..metrics.sums import np_sum
from .trace import TRACE_GROUP, TraceRing, read_rows, score_columns

BLOCK = TraceRing.BLOCK


MDEV_KEYS = ("mdev_basic_m", "mdev_adapted_m", "adapted_start_before_sign_m", "adapted_length_per_lane_m", "adapted_habitual_offset_m")
TAIL_KEYS = ("lane_changes", "lane_changes_correct", "lane_change_errors", "mean_lane_change_latency_s")
N_KEYS = len(episode_scores.KEYS)
N_BASE = 22 + N_KEYS - 9  # `platoon._BASE_KEYS`' length: `OpenDSEnv.episode_metrics`' keys


def wide_keys(base_keys: tuple[str, ...], signs: int) -> tuple[str, ...]:
    """Every key an LCT episode of `signs` metric signs can have, in the wide row's order:
    the base keys, signs_reached, `MDEV_KEYS`, each sign's latency, reached flag and timer
    result, then `TAIL_KEYS`."""
    if len(base_keys) != N_BASE:
        raise ValueError(f"the LCT's wide row has {N_BASE} base keys, not {len(base_keys)}")
    per_sign = tuple(f"sign{k:02d}_{what}" for k in range(signs) for what in ("latency_s", "reached", "timer_result"))
    return (*base_keys, "signs_reached", *MDEV_KEYS, *per_sign, *TAIL_KEYS)


@functools.cache
def row_columns(signs: int, passed: int) -> tuple[int, ...]:
    """The wide row's columns of an episode that passed `passed` signs, in the order of
    `LaneChangeTestEnv.episode_metrics`' keys (no sign passed: no adapted model, no sign keys)."""
    head = tuple(range(N_BASE + 1))
    tail = tuple(range(N_BASE + 6 + 3 * signs, N_BASE + 10 + 3 * signs))
    if passed == 0:
        return (*head, N_BASE + 1, N_BASE + 2, *tail)
    return (*head, *range(N_BASE + 1, N_BASE + 6 + 3 * passed), *tail)


@functools.cache
def table_layout(keys: tuple[str, ...], signs: int, passed_order: tuple[int, ...]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray | None]:
    """For episodes whose distinct sign counts first appear in `passed_order`: the table's
    keys (in order of first appearance over the rows, as `env._metrics_arrays` orders them;
    `keys`: `wide_keys`'), their wide columns and each distinct count's presence row over
    them (None: one count, every key present)."""
    order: dict[int, int] = {}
    for p in passed_order:
        for c in row_columns(signs, p):
            order.setdefault(c, len(order))
    columns = np.fromiter(order, dtype=np.int64, count=len(order))
    names = tuple(keys[c] for c in order)
    if len(passed_order) == 1:
        return names, columns, None
    present = np.zeros((max(passed_order) + 1, len(columns)), dtype=np.bool_)
    for p in passed_order:
        present[p, [order[c] for c in row_columns(signs, p)]] = True
    return names, columns, present


@parallel_kernel
def lct_score_episodes(es: np.ndarray, blocks: np.ndarray, b0: int, first: tuple, start: np.ndarray, steps: np.ndarray, trace_p: tuple,
                       score_p: tuple, lct_p: tuple, env_p: tuple, react: tuple, wide: np.ndarray, passed: np.ndarray) -> None:  # fmt: skip
    """`score_episodes` with each episode on one of numba's threads."""
    for j in prange(len(es)):
        score_episodes(j, j + 1, es, blocks, b0, first, start, steps, trace_p, score_p, lct_p, env_p, react, wide, passed)


@kernel
def read_episode(e: int, blocks: np.ndarray, b0: int, first: tuple, start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Env e's episode so far from the LCT's grouped `TraceRing` (reset row first) as (column, row)
    (`trace.read_rows`)."""
    out = np.empty((len(first), steps[e] + 1))
    read_rows(e, blocks, b0, (BLOCK // TRACE_GROUP, len(start), TRACE_GROUP, len(first)), first, start, steps, out, 0)
    return out


@kernel
def score_episodes(j0: int, j1: int, es: np.ndarray, blocks: np.ndarray, b0: int, first: tuple, start: np.ndarray, steps: np.ndarray,
                   trace_p: tuple, score_p: tuple, lct_p: tuple, env_p: tuple, react: tuple, wide: np.ndarray,
                   passed: np.ndarray) -> None:  # fmt: skip
    """Episodes j0..j1-1 (env es[j]: its trace read straight from the ring, `read_episode`:
    x, z, speed, steering) into wide[j] (`wide_keys`' columns; the sign keys of the signs
    passed only) and passed[j] (the signs passed and scored; -1: the episode passed a sign
    but has too few rows for the compiled fits: the caller scores it the template's way).
    trace_p: (dt, road sign, lane centres, half lane width, steering wheel max (deg));
    score_p: `episode_scores.scoring_params`; lct_p: (start z, metric signs' d, from lane, to
    lane, visibility, basic start before sign, length per lane, lane laterals, initial lane,
    the track speed (m/s)); env_p: (sim time, fuel used, collisions per env, then lanes known,
    resets, collision resets, reset time); react: the timers' (n_results, result_code,
    result_rt, result_spec, sign_of_spec)."""
    dt, sign, centres, half, steer_max = trace_p
    b, a, zi, p, gaps, thw, ttc = score_p
    start_z, sign_d, sign_from, sign_to, visibility, start_before, per_lane, lane_lat, initial_lane, speed_mps = lct_p
    t_env, fuel, collisions, consts = env_p
    n_results, code, rt, spec, sign_of_spec = react
    n_gaps, n_signs = len(gaps), len(sign_d)
    st = np.zeros(2, dtype=np.int64)
    for j in range(j0, j1):
        e = es[j]
        data = read_episode(e, blocks, b0, first, start, steps)
        n = data.shape[1]
        st[1] = n
        x, z, speed, steer = data[0], data[1], data[2], data[3]
        derived = np.empty((6, n))  # t, lateral, lane, offset, steering (deg), distance to the next row
        score_columns(st, x, z, steer, dt, sign, centres, half, steer_max, derived)
        t, lat, lane, off, steer_deg, ds = derived[0], derived[1], derived[2], derived[3], derived[4], derived[5]
        base = np.empty((1, N_KEYS))
        # (no traffic: the gap, lead speed, headway and TTC arguments are not read; `speed` stands in for them)
        episode_scores.episode_scores(st, t, ds, speed, steer_deg, speed, speed, speed, speed, lat, lane, off, b, a, zi, p, gaps, thw, ttc,
                                      base, False, False)  # fmt: skip
        lct = np.empty((1, J2944 + n_gaps + 3))
        lct_scores(st, t, z, lat, steer_deg, start_z, sign_d, sign_from, sign_to, visibility, start_before, per_lane, lane_lat,
                   initial_lane, b, a, zi, p, gaps, lct)  # fmt: skip
        row = base[0]
        for k in range(J2944 + n_gaps):
            row[9 + k] = lct[0, k]
        reached, presented, n_passed = lct[0, J2944 + n_gaps], lct[0, J2944 + n_gaps + 1], int(lct[0, J2944 + n_gaps + 2])
        ps = n_passed if n >= 2 else 0
        passed[j] = -1 if n_passed and not ps else ps
        mdev, fits = np.full((1, 5), math.nan), np.zeros((1, n_signs, 2))
        if ps:
            lct_lane_changes(st, z, lat, start_z, sign_d, sign_from, sign_to, np.array([ps]), visibility, start_before, per_lane,
                             lane_lat, initial_lane, mdev, fits)  # fmt: skip
        # reactions (`LaneChangeTestEnv._timer_results` and `OpenDSEnv.episode_metrics`' counts)
        nr = n_results[e]
        correct, failed, missed = 0, 0, 0
        buf = np.empty(max(nr, n_signs))
        timer = np.zeros(n_signs)
        for i in range(nr):
            if code[e, i] == 1:
                buf[correct] = rt[e, i]
                correct += 1
            elif code[e, i] == -1:
                failed += 1
            elif code[e, i] == -2:
                missed += 1
            s = sign_of_spec[spec[e, i]]
            if s >= 0 and s < n_signs:
                timer[s] = code[e, i]
        w = wide[j]
        w[0], w[1], w[2], w[3], w[4] = t_env[e], row[0], row[1], fuel[e], collisions[e]
        for k in range(4):
            w[5 + k] = row[2 + k]
        w[9], w[10], w[11], w[12] = nr, correct, failed, missed
        w[13] = np_sum(buf, 0, correct) / correct if correct else math.nan
        w[14], w[15], w[16], w[17], w[18] = consts[0], row[6], row[7], presented, row[8]
        w[19], w[20], w[21] = consts[1], consts[2], consts[3]
        for k in range(9, N_KEYS):
            w[22 + k - 9] = row[k]
        w[N_BASE] = reached
        for k in range(5):
            w[N_BASE + 1 + k] = mdev[0, k]
        right, m = 0, 0
        for k in range(ps):
            latency_m, hit = fits[0, k, 0], fits[0, k, 1]
            latency_s = latency_m / speed_mps if math.isfinite(latency_m) else math.nan
            if math.isfinite(latency_s):
                buf[m] = latency_s
                m += 1
            at = N_BASE + 6 + 3 * k
            w[at], w[at + 1], w[at + 2] = latency_s, hit, timer[k]
            if hit:
                right += 1
        at = N_BASE + 6 + 3 * n_signs
        w[at], w[at + 1], w[at + 2] = ps, right, ps - right
        w[at + 3] = np_sum(buf, 0, m) / m if m else math.nan
