"""Traffic paths pre-sampled into flat numpy arrays, looked up by (path id, arc length).

Why: every traffic object moves a point (its follow box, or itself) along a path each
step. Keeping all paths in one set of arrays with a global arc-length axis lets one
`np.searchsorted` answer the lookups of every object at once, with no per-object Python.

Curves follow jME's `Spline` (what OpenDS's `MotionPath` and road segments use):
Catmull-Rom through the control points with the file's curve tension; an open spline gets
mirrored phantom end points, a cyclic one is closed through its first point.
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import inline, kernel

SAMPLE_SPACING_M = 1.0  # curved pieces are sampled about this finely (straight ones exactly)
PATH_GAP_M = 1.0  # spacing between paths on the global arc-length axis


def catmull_rom(ctrl: np.ndarray, tension: float, cyclic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Sample a jME Catmull-Rom spline through `ctrl` (K,3).

    Returns (points (M,3), knot index (K or K+1,)): the sample index of every control point
    (for a cyclic spline the first point is repeated at the end).
    """
    pts = np.asarray(ctrl, dtype=float)
    if cyclic and len(pts) >= 2:
        pts = np.vstack([pts, pts[:1]])
    if len(pts) < 2:
        p = pts if len(pts) else np.zeros((1, 3))
        return np.vstack([p[:1], p[:1]]), np.array([0, 1])
    if cyclic:
        before, after = pts[-2], pts[1]
    else:
        before, after = 2.0 * pts[0] - pts[1], 2.0 * pts[-1] - pts[-2]
    cr = np.vstack([before, pts, after])
    T = float(tension)
    out = [pts[:1]]
    knots = [0]
    for j in range(len(pts) - 1):
        p0, p1, p2, p3 = cr[j], cr[j + 1], cr[j + 2], cr[j + 3]
        n = int(min(200, max(4, math.ceil(float(np.linalg.norm(p2 - p1)) / SAMPLE_SPACING_M))))
        u = (np.arange(1, n + 1) / n)[:, None]
        c2 = -T * p0 + T * p2
        c3 = 2 * T * p0 + (T - 3) * p1 + (3 - 2 * T) * p2 - T * p3
        c4 = -T * p0 + (2 - T) * p1 + (T - 2) * p2 + T * p3
        piece = ((c4 * u + c3) * u + c2) * u + p1
        piece[-1] = p2  # land exactly on the control point
        out.append(piece)
        knots.append(knots[-1] + n)
    return np.vstack(out), np.asarray(knots)


def polyline(ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A straight-piece path (jME's Linear spline): the control points themselves."""
    pts = np.asarray(ctrl, dtype=float)
    if len(pts) < 2:
        p = pts if len(pts) else np.zeros((1, 3))
        return np.vstack([p[:1], p[:1]]), np.array([0, 1])
    return pts, np.arange(len(pts))


# rows of `PathBank.arrays()`: per sample (pf), per path (pp floats, pi ints)
PF_X, PF_Y, PF_Z, PF_S, PF_DX, PF_DY, PF_DZ, PF_OK, PF_LEN, PF_YAW = range(10)
PP_OFF, PP_LEN = 0, 1
PI_FIRST, PI_LAST_PIECE = 0, 1


@inline
def sample_point(pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, pid: int, s: float, hint: int) -> tuple[float, float, float, float, int]:
    """(x, y, z, yaw, piece) at arc length s (clamped to the path) on path `pid` (m, rad).

    `piece` is the sample the point lies after; passed back as `hint` next time, the usual
    lookup (a carrot moved a little) skips the binary search. The result never depends on it.
    """
    length = pp[PP_LEN, pid]
    g = pp[PP_OFF, pid] + ((s if s > 0.0 else 0.0) if s < length else length)
    first, last = pi[PI_FIRST, pid], pi[PI_LAST_PIECE, pid] + 1
    # the last sample at or before g (the path's first one is at its offset, so there is one)
    if first <= hint < last and pf[PF_S, hint] <= g < pf[PF_S, hint + 1]:
        lo = hint
    elif first <= hint < last - 1 and pf[PF_S, hint + 1] <= g < pf[PF_S, hint + 2]:
        lo = hint + 1
    else:
        lo = piece_at(pf, first, last, g)
    k = lo if lo < last - 1 else last - 1
    f = (g - pf[PF_S, k]) / pf[PF_LEN, k] if pf[PF_OK, k] != 0.0 else 0.0
    return pf[PF_X, k] + f * pf[PF_DX, k], pf[PF_Y, k] + f * pf[PF_DY, k], pf[PF_Z, k] + f * pf[PF_DZ, k], pf[PF_YAW, k], k


@kernel
def piece_at(pf: np.ndarray, first: int, last: int, g: float) -> int:
    """The last sample of first..last at or before global arc length g (binary search)."""
    lo, hi = first, last
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if pf[PF_S, mid] <= g:
            lo = mid
        else:
            hi = mid - 1
    return lo


@kernel
def _sample_many(pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, pid: np.ndarray, s: np.ndarray, out: np.ndarray) -> None:
    for k in range(len(pid)):
        out[0, k], out[1, k], out[2, k], out[3, k], _ = sample_point(pf, pp, pi, pid[k], s[k], -1)


@kernel
def _point(pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, pid: int, s: float) -> tuple[float, float, float, float]:
    x, y, z, yaw, _ = sample_point(pf, pp, pi, pid, s, -1)
    return x, y, z, yaw


class PathBank:
    """All paths of a traffic manager. Paths may be added at any time (rarely)."""

    def __init__(self) -> None:
        self._paths: list[np.ndarray] = []
        self._dirty = True
        self._length = np.zeros(0)
        self._build()

    @property
    def length(self) -> np.ndarray:
        """Length (m, in the ground plane) of every path."""
        self._build()
        return self._length

    def add(self, points: np.ndarray) -> int:
        """Add a sampled path (M,3), M >= 2; returns its id."""
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 2:
            raise ValueError("a path needs at least two (x, y, z) points")
        self._paths.append(pts)
        self._dirty = True
        return len(self._paths) - 1

    def arc_lengths(self, pid: int) -> np.ndarray:
        """Cumulative arc length (in the ground plane) at every sample of a path."""
        p = self._paths[pid]
        return np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(p[:, 0]), np.diff(p[:, 2])))])

    def __len__(self) -> int:
        return len(self._paths)

    def truncate(self, n: int) -> None:
        """Forget paths added after the first `n` (used when restoring a state)."""
        if len(self._paths) != n:
            del self._paths[n:]
            self._dirty = True

    def extra(self, n: int) -> list[np.ndarray]:
        return [p.copy() for p in self._paths[n:]]

    def _build(self) -> None:
        if not self._dirty:
            return
        xs, ys, zs, ss, first, last, length, off = [], [], [], [], [], [], [], []
        base, count = 0.0, 0
        for k in range(len(self._paths)):
            p = self._paths[k]
            s = self.arc_lengths(k)
            xs.append(p[:, 0])
            ys.append(p[:, 1])
            zs.append(p[:, 2])
            ss.append(base + s)
            first.append(count)
            last.append(count + len(p) - 1)
            off.append(base)
            length.append(float(s[-1]))
            count += len(p)
            base += float(s[-1]) + PATH_GAP_M
        cat = (lambda a: np.concatenate(a)) if self._paths else (lambda a: np.zeros(0))
        self._x, self._y, self._z, self._s = cat(xs), cat(ys), cat(zs), cat(ss)
        self._first = np.asarray(first, dtype=np.int64)
        self._last = np.asarray(last, dtype=np.int64)
        self._off = np.asarray(off)
        self._length = np.asarray(length)
        dx = np.diff(self._x) if len(self._x) > 1 else np.zeros(0)
        dz = np.diff(self._z) if len(self._z) > 1 else np.zeros(0)
        seg = np.hypot(dx, dz)
        yaw = np.arctan2(-dx, -dz)
        # zero-length pieces take the heading of the nearest real piece of their path
        for k in range(len(self._paths)):
            a, b = self._first[k], self._last[k]
            if b <= a:
                continue
            y, L = yaw[a:b], seg[a:b]
            ok = L > 1e-9
            if not ok.any():
                y[:] = 0.0
            elif not ok.all():
                idx = np.where(ok, np.arange(len(L)), -1)
                idx = np.maximum.accumulate(idx)
                idx[idx < 0] = np.flatnonzero(ok)[0]
                y[:] = y[idx]
        m = len(self._x)
        pf = np.zeros((10, m))
        pf[PF_X], pf[PF_Y], pf[PF_Z], pf[PF_S] = self._x, self._y, self._z, self._s
        if m > 1:
            ok = seg > 1e-9
            pf[PF_DX, :-1], pf[PF_DY, :-1], pf[PF_DZ, :-1] = dx, np.diff(self._y), dz
            pf[PF_OK, :-1], pf[PF_LEN, :-1], pf[PF_YAW, :-1] = ok, np.where(ok, seg, 1.0), yaw
        pp = np.array([self._off, self._length]).reshape(2, -1)
        pi = np.array([self._first, np.maximum(self._first, self._last - 1)], dtype=np.int64).reshape(2, -1)
        self._arrays = (pf, pp, pi)
        self._dirty = False

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The sampled paths for the kernels: (per sample: x, y, z, global arc length, the step
        to the next sample, whether it has length, its length, its heading; per path: offset on
        the global axis, length; per path: first sample, last piece)."""
        if self._dirty:
            self._build()
        return self._arrays

    def sample(self, pid: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, z, yaw) at arc length s (clamped to the path) on each path id."""
        pid = np.ascontiguousarray(pid, dtype=np.int64)
        s = np.ascontiguousarray(np.broadcast_to(s, pid.shape), dtype=np.float64)
        out = np.empty((4, len(pid)))
        _sample_many(*self.arrays(), pid, s, out)
        return out[0], out[1], out[2], out[3]

    def point(self, pid: int, s: float) -> tuple[float, float, float, float]:
        return _point(*self.arrays(), int(pid), float(s))  # type: ignore[no-any-return]

    def project(self, pid: int, x: float, z: float) -> tuple[float, float]:
        """(arc length of the closest point, distance to it) of a point on one path."""
        self._build()
        a, b = int(self._first[pid]), int(self._last[pid])
        px, pz, ps = self._x[a : b + 1], self._z[a : b + 1], self._s[a : b + 1] - self._off[pid]
        dx, dz = np.diff(px), np.diff(pz)
        L2 = dx * dx + dz * dz
        t = np.clip(((x - px[:-1]) * dx + (z - pz[:-1]) * dz) / np.where(L2 > 1e-12, L2, 1.0), 0.0, 1.0)
        qx, qz = px[:-1] + t * dx, pz[:-1] + t * dz
        d2 = (qx - x) ** 2 + (qz - z) ** 2
        j = int(np.argmin(d2))
        return float(ps[j] + t[j] * (ps[j + 1] - ps[j])), float(math.sqrt(d2[j]))

    def window(self, pid: int, s0: float, s1: float, spacing_m: float = 2.0) -> np.ndarray:
        """Points (K,2) every `spacing_m` along a path between two arc lengths (lane-clear tests)."""
        s0, s1 = max(0.0, s0), min(float(self.length[pid]), s1)
        n = max(2, int(math.ceil(max(0.0, s1 - s0) / spacing_m)) + 1)
        x, _, z, _ = self.sample(np.full(n, pid), np.linspace(s0, s1, n))
        return np.column_stack([x, z])
