"""The brake and platoon batches' ended episodes: derived trace columns and generic scores in one parallel pass.

Why: under random actions a 4,096-env platoon batch ends ~190 episodes per step, and their
scoring (`trace.score_columns`, then `metrics.episode_scores` over all of them) ran on the
calling thread while numba's other threads waited: ~0.6 ms of a ~7 ms step on two cores,
more of it on more. Here chunks of episodes are scored on numba's threads, each chunk by
the same two kernels on its own rows. Every score is a reduction over one episode's
samples, so the floats do not depend on the chunks (the per-step distance of a chunk's last
row, which no score reads, is 0 instead of the distance to the next episode's first row).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ..jit import kernel, parallel_kernel
from ..metrics.episode_scores import episode_scores
from .trace import score_columns


@parallel_kernel
def score_episodes(chunks: int, starts: np.ndarray, x: np.ndarray, z: np.ndarray, steer: np.ndarray, speed: np.ndarray, gap: np.ndarray,
                   lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray, trace_p: tuple, score_p: tuple, off: np.ndarray,
                   out: np.ndarray) -> None:  # fmt: skip
    """`score_range` of every episode, `chunks` chunks of them on numba's threads (`trace.episode_chunks`)."""
    m = len(starts) - 1
    for k in prange(chunks):
        score_range(k * m // chunks, (k + 1) * m // chunks, starts, x, z, steer, speed, gap, lead_v, headway, ttc, trace_p, score_p, off,
                    out)  # fmt: skip


@kernel
def score_range(j0: int, j1: int, starts: np.ndarray, x: np.ndarray, z: np.ndarray, steer: np.ndarray, speed: np.ndarray,
                gap: np.ndarray, lead_v: np.ndarray, headway: np.ndarray, ttc: np.ndarray, trace_p: tuple, score_p: tuple, off: np.ndarray,
                out: np.ndarray) -> None:  # fmt: skip
    """`episode_scores.KEYS` of episodes j = j0..j1-1 into out[j], and each of their rows' lane
    offset into `off`: rows starts[j]..starts[j+1]-1 of the trace columns (x, z, steering
    input, speed, gap, lead speed, headway, TTC) are episode j's, reset row first. trace_p:
    (dt, road sign, lane centres, half lane width, steering wheel max (deg)); score_p:
    `episode_scores.scoring_params`."""
    dt, sign, centres, half, steer_max = trace_p
    b, a, zi, p, gaps, thw, ttc_th = score_p
    lo, hi = starts[j0], starts[j1]
    st = starts[j0 : j1 + 1] - lo
    d = np.empty((6, hi - lo))  # t, lateral, lane, offset, steering (deg), step to the next row
    score_columns(st, x[lo:hi], z[lo:hi], steer[lo:hi], dt, sign, centres, half, steer_max, d)
    episode_scores(st, d[0], d[5], speed[lo:hi], d[4], gap[lo:hi], lead_v[lo:hi], headway[lo:hi], ttc[lo:hi], d[1], d[2], d[3], b, a, zi,
                   p, gaps, thw, ttc_th, out[j0:j1])  # fmt: skip
    off[lo:hi] = d[3]
