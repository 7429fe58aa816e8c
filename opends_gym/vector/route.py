"""Lane measures on a route guide for a native batch: `RoadGuide.lane_position` per env, compiled.

Why: tasks whose lanes are measured along the ego's route (`RoadGuide` kind "route": a
slip road joined to the task's road, Gen B segments, a curved road) need the foot point on a
polyline every physics step. The single env walks from the last answer's segment
(`RoadGuide._route_foot`) and checks an answer off the line against the whole route
(`Polyline.project`); here the same walk runs per env, with each env's own hint, with the
same arithmetic (so the same floats), and the running SDLP and mean-deviation terms of
`OpenDSEnv._record_row` follow it as in `kernels.lane_measures`.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import inline, kernel, py_hypot, python_buffers, whole_batch
from ..sim.guide import _SURE_M, _WALK_MAX, RoadGuide
from .kernels import lane_of

# columns of a route segment row (`RoadGuide._seg`): start, direction, length, arc length at the start, heading
R_AX, R_AZ, R_DX, R_DZ, R_L, R_S0, R_HEADING = range(7)


def route_tables(guide: RoadGuide) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(segment table, polyline points, polyline arc lengths, polyline segment lengths) of a
    route guide, the single env's own floats."""
    if guide.kind != "route" or guide.polyline is None:
        raise ValueError("a route table needs a road guide of kind 'route'")
    seg = np.array(guide._seg, dtype=np.float64).reshape(-1, 7)
    poly = guide.polyline
    return seg, np.ascontiguousarray(poly.xz, dtype=np.float64), np.ascontiguousarray(poly.s, dtype=np.float64), \
        np.ascontiguousarray(poly.seg_len, dtype=np.float64)  # fmt: skip


@inline
def _project(x: float, z: float, xz: np.ndarray, ps: np.ndarray, seg_len: np.ndarray) -> tuple[float, float, int]:
    """`Polyline.project`: (s, offset + left, segment) of the closest point (the first of equals)."""
    best, k, tk = math.inf, 0, 0.0
    for j in range(len(seg_len)):
        ax, az = xz[j, 0], xz[j, 1]
        dx, dz = xz[j + 1, 0] - ax, xz[j + 1, 1] - az
        L2 = seg_len[j] * seg_len[j]
        L2 = L2 if L2 >= 1e-12 else 1e-12
        t = ((x - ax) * dx + (z - az) * dz) / L2
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
        px, pz = ax + t * dx, az + t * dz
        d2 = (px - x) * (px - x) + (pz - z) * (pz - z)
        if d2 < best:
            best, k, tk = d2, j, t
    ax, az = xz[k, 0], xz[k, 1]
    dx, dz = xz[k + 1, 0] - ax, xz[k + 1, 1] - az
    px, pz = ax + tk * dx, az + tk * dz
    sl = seg_len[k] if seg_len[k] != 0.0 else 1.0
    lx, lz = dz / sl, -dx / sl
    return ps[k] + tk * seg_len[k], (x - px) * lx + (z - pz) * lz, k


@inline
def route_foot(x: float, z: float, seg: np.ndarray, hint: int, xz: np.ndarray, ps: np.ndarray,
               seg_len: np.ndarray) -> tuple[float, float, float, int]:  # fmt: skip
    """`RoadGuide._route_foot` from segment `hint`: (s, lateral + left, heading, the new hint)."""
    n = seg.shape[0]
    k = hint
    t = 0.0
    for _ in range(_WALK_MAX):
        ax, az, dx, dz, L = seg[k, R_AX], seg[k, R_AZ], seg[k, R_DX], seg[k, R_DZ], seg[k, R_L]
        t = ((x - ax) * dx + (z - az) * dz) / (L * L)
        if t > 1.0 and k + 1 < n:
            bx, bz, ex, ez = seg[k + 1, R_AX], seg[k + 1, R_AZ], seg[k + 1, R_DX], seg[k + 1, R_DZ]
            if ((x - bx) * ex + (z - bz) * ez) < 0.0:  # outside a corner: its vertex
                t = 1.0
                break
            k += 1
        elif t < 0.0 and k > 0:
            bx, bz, ex, ez, M = seg[k - 1, R_AX], seg[k - 1, R_AZ], seg[k - 1, R_DX], seg[k - 1, R_DZ], seg[k - 1, R_L]
            if ((x - bx) * ex + (z - bz) * ez) > M * M:
                t = 0.0
                break
            k -= 1
        else:
            break
    t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
    px, pz = seg[k, R_AX] + t * seg[k, R_DX], seg[k, R_AZ] + t * seg[k, R_DZ]
    ex, ez = x - px, z - pz
    d2 = ex * ex + ez * ez
    k0 = k
    for side in range(2):  # inside a bend two segments hold a foot point: the nearer one
        j = k0 - 1 if side == 0 else k0 + 1
        if 0 <= j < n:
            bx, bz, fx, fz, M = seg[j, R_AX], seg[j, R_AZ], seg[j, R_DX], seg[j, R_DZ], seg[j, R_L]
            u = ((x - bx) * fx + (z - bz) * fz) / (M * M)
            u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
            gx, gz = x - bx - u * fx, z - bz - u * fz
            if gx * gx + gz * gz < d2 - 1e-12:
                k, t, d2, ex, ez = j, u, gx * gx + gz * gz, gx, gz
    if d2 > _SURE_M * _SURE_M:  # off the line: the whole route may hold a nearer point
        qs, qoff, qk = _project(x, z, xz, ps, seg_len)
        if qoff * qoff < d2 - 1e-12:
            return qs, qoff, seg[qk, R_HEADING], qk
    dx, dz, L = seg[k, R_DX], seg[k, R_DZ], seg[k, R_L]
    return seg[k, R_S0] + t * L, (ex * dz - ez * dx) / L, seg[k, R_HEADING], k


@kernel
def locate_route(x: np.ndarray, z: np.ndarray, rows: np.ndarray, seg: np.ndarray, xz: np.ndarray, ps: np.ndarray, seg_len: np.ndarray,
                 hint: np.ndarray, s_out: np.ndarray) -> None:  # fmt: skip
    """`RoadGuide.locate(x, z).s_m` for the envs `rows` (their hints move on)."""
    for e in range(len(x)):
        if rows[e]:
            s_out[e], _, _, hint[e] = route_foot(x[e], z[e], seg, hint[e], xz, ps, seg_len)


@whole_batch
@python_buffers
@kernel
def record_route(x: np.ndarray, z: np.ndarray, rows: np.ndarray, first: np.ndarray, seg: np.ndarray, xz: np.ndarray, ps: np.ndarray,
                 seg_len: np.ndarray, hint: np.ndarray, centres: np.ndarray, half_width: float, keep_m: float, s_out: np.ndarray,
                 heading: np.ndarray, lat: np.ndarray, lane: np.ndarray, offset: np.ndarray, n: np.ndarray, mean: np.ndarray,
                 m2: np.ndarray, prev_x: np.ndarray, prev_z: np.ndarray, dist: np.ndarray, area: np.ndarray) -> None:  # fmt: skip
    """`OpenDSEnv._record_row`'s lane measures on a route for the envs `rows`: s, lateral
    position, heading of the route, lane (-1 off the lanes), offset from the lane's centre
    (or the nearest lane's), the running SDLP terms and the distance and area of the mean
    deviation (none for a first row)."""
    for e in range(len(x)):
        if not rows[e]:
            continue
        s, la, hd, hint[e] = route_foot(x[e], z[e], seg, hint[e], xz, ps, seg_len)
        ln, ref = lane_of(la, centres, half_width)
        off = la - centres[ref]
        if not first[e]:
            ds = py_hypot(x[e] - prev_x[e], z[e] - prev_z[e])
            dist[e] = dist[e] + ds
            area[e] = area[e] + 0.5 * (abs(offset[e]) + abs(off)) * ds
        if abs(off) < keep_m:
            count = n[e] + 1.0
            d = off - mean[e]
            mean[e] = mean[e] + d / count
            m2[e] = m2[e] + d * (off - mean[e])
            n[e] = count
        s_out[e], heading[e], lat[e], lane[e], offset[e] = s, hd, la, ln, off
        prev_x[e], prev_z[e] = x[e], z[e]
