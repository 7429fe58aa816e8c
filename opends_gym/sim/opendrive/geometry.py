"""OpenDRIVE plan-view geometry: reference-line primitives and cubic polynomials.

Why: roads in `.xodr` files are chains of lines, arcs, clothoids (spirals), cubic
polynomials (poly3) and parametric cubics (paramPoly3). Lanes, triggers and traffic routes
all need the reference line at arbitrary `s` (position, heading, curvature), so each
primitive evaluates a whole array of `s` offsets at once.

Everything here is in OpenDRIVE's own frame (x east, y north, heading counter-clockwise
from +x); `opendrive.py` converts to world coordinates. Clothoids are integrated with
composite Gauss-Legendre quadrature (scipy is not a dependency; the heading is a
quadratic in `s`, so a few 8-node panels per radian of turning are exact to ~1e-12 m).
Poly3 and paramPoly3 are re-parametrised by true arc length through a dense table, so `s`
is a distance along the road whatever the file's parameter range.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

FloatArray = np.ndarray

_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = 0.5 * (_GL_X + 1.0)  # nodes on [0, 1]
_GL_W = 0.5 * _GL_W
_ARC_TABLE_STEP_M = 0.25  # resolution of the arc-length tables of poly3 / paramPoly3


@dataclass(frozen=True)
class Cubic:
    """A piecewise cubic `a + b*ds + c*ds^2 + d*ds^3`, ds = s - start of the active record.

    Used for lane widths, lane borders, laneOffset and elevation. Records are sorted by
    their start; before the first record the first one applies (OpenDRIVE leaves that
    case undefined; real files start at 0).
    """

    starts: FloatArray = field(default_factory=lambda: np.zeros(0))
    coef: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))  # (n, 4): a, b, c, d

    @staticmethod
    def from_records(records: list[tuple[float, float, float, float, float]]) -> Cubic:
        """`records` are (start, a, b, c, d); a stable sort by start keeps file order on ties."""
        recs = sorted(records, key=lambda r: r[0])
        if not recs:
            return Cubic()
        arr = np.asarray(recs, dtype=float)
        return Cubic(arr[:, 0].copy(), arr[:, 1:].copy())

    def __post_init__(self) -> None:
        # plain-Python copies for the scalar path (locate runs every physics step)
        object.__setattr__(self, "_starts_list", [float(v) for v in self.starts])
        object.__setattr__(self, "_coef_list", [tuple(float(c) for c in row) for row in self.coef])

    @property
    def empty(self) -> bool:
        return len(self.starts) == 0

    def at(self, s: float) -> float:
        """Scalar evaluation without numpy overhead."""
        starts: list[float] = self._starts_list  # type: ignore[attr-defined]
        if not starts:
            return 0.0
        i = min(max(bisect.bisect_right(starts, s) - 1, 0), len(starts) - 1)
        a, b, c, d = self._coef_list[i]  # type: ignore[attr-defined]
        ds = s - starts[i]
        return a + ds * (b + ds * (c + ds * d))

    def _index(self, s: FloatArray) -> FloatArray:
        return np.clip(np.searchsorted(self.starts, s, side="right") - 1, 0, len(self.starts) - 1)

    def _piece(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The coefficients (a, b, c, d) of each s's piece and the distance into it."""
        i = self._index(s)
        return self.coef[i].T, s - self.starts[i]

    def __call__(self, s: FloatArray | float) -> FloatArray:
        s = np.asarray(s, dtype=float)
        if self.empty:
            return np.zeros_like(s)
        (a, b, c, d), ds = self._piece(s)
        return a + ds * (b + ds * (c + ds * d))

    def derivative(self, s: FloatArray | float) -> FloatArray:
        s = np.asarray(s, dtype=float)
        if self.empty:
            return np.zeros_like(s)
        (_, b, c, d), ds = self._piece(s)
        return b + ds * (2.0 * c + ds * 3.0 * d)


@dataclass(frozen=True)
class RefSample:
    """Reference-line samples: position, heading (rad, ccw from +x) and curvature (1/m)."""

    x: FloatArray
    y: FloatArray
    hdg: FloatArray
    kappa: FloatArray


class Geometry:
    """One `<geometry>` record: start s, start pose and length; subclasses give the shape."""

    kind = "geometry"

    def __init__(self, s0: float, x0: float, y0: float, hdg0: float, length: float) -> None:
        self.s0, self.x0, self.y0, self.hdg0, self.length = s0, x0, y0, hdg0, length

    def local(self, ds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(u, v, heading, curvature) in the geometry's frame (origin at start, u along hdg0)."""
        raise NotImplementedError

    def point(self, ds: float) -> tuple[float, float, float, float]:
        """(x, y, heading, curvature) at one offset; subclasses with closed forms skip numpy."""
        r = self.evaluate(np.array([ds]))
        return float(r.x[0]), float(r.y[0]), float(r.hdg[0]), float(r.kappa[0])

    def evaluate(self, ds: FloatArray) -> RefSample:
        """The reference line at offsets `ds` (0..length) from this geometry's start."""
        ds = np.clip(np.asarray(ds, dtype=float), 0.0, self.length)
        u, v, h, k = self.local(ds)
        c, s = math.cos(self.hdg0), math.sin(self.hdg0)
        return RefSample(self.x0 + c * u - s * v, self.y0 + s * u + c * v, self.hdg0 + h, k)


class Line(Geometry):
    kind = "line"

    def point(self, ds: float) -> tuple[float, float, float, float]:
        ds = min(max(ds, 0.0), self.length)
        return self.x0 + ds * math.cos(self.hdg0), self.y0 + ds * math.sin(self.hdg0), self.hdg0, 0.0

    def local(self, ds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        z = np.zeros_like(ds)
        return ds, z, z, z


class Arc(Geometry):
    kind = "arc"

    def __init__(self, s0: float, x0: float, y0: float, hdg0: float, length: float, curvature: float) -> None:
        super().__init__(s0, x0, y0, hdg0, length)
        self.curvature = curvature

    def point(self, ds: float) -> tuple[float, float, float, float]:
        ds = min(max(ds, 0.0), self.length)
        k = self.curvature
        if abs(k) < 1e-12:
            return self.x0 + ds * math.cos(self.hdg0), self.y0 + ds * math.sin(self.hdg0), self.hdg0, 0.0
        h = self.hdg0 + k * ds
        return self.x0 + (math.sin(h) - math.sin(self.hdg0)) / k, self.y0 - (math.cos(h) - math.cos(self.hdg0)) / k, h, k

    def local(self, ds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        k = self.curvature
        if abs(k) < 1e-12:
            z = np.zeros_like(ds)
            return ds, z, z, z
        a = k * ds
        return np.sin(a) / k, (1.0 - np.cos(a)) / k, a, np.full_like(ds, k)


class Spiral(Geometry):
    """Clothoid: curvature changes linearly from curvStart to curvEnd over the length."""

    kind = "spiral"

    def __init__(self, s0: float, x0: float, y0: float, hdg0: float, length: float, curv_start: float, curv_end: float) -> None:
        super().__init__(s0, x0, y0, hdg0, length)
        self.k0 = curv_start
        self.rate = (curv_end - curv_start) / length if length > 0 else 0.0
        # composite Gauss-Legendre on [0, 1]: one 8-node panel per half radian of turning
        turn = abs(curv_start) * length + 0.5 * abs(self.rate) * length**2
        panels = int(min(400, max(1, math.ceil(turn / 0.5))))
        edges = np.linspace(0.0, 1.0, panels + 1)
        self._nodes = (edges[:-1, None] + (edges[1:] - edges[:-1])[:, None] * _GL_X[None, :]).ravel()
        self._weights = np.repeat(np.diff(edges), len(_GL_X)) * np.tile(_GL_W, panels)
        self._quad = list(zip(self._nodes.tolist(), self._weights.tolist(), strict=True))

    def point(self, ds: float) -> tuple[float, float, float, float]:
        ds = min(max(ds, 0.0), self.length)
        k0, c = self.k0, self.rate
        u = v = 0.0
        for xi, w in self._quad:
            t = ds * xi
            th = t * (k0 + 0.5 * c * t)
            u += w * math.cos(th)
            v += w * math.sin(th)
        u, v = u * ds, v * ds
        ch, sh = math.cos(self.hdg0), math.sin(self.hdg0)
        return self.x0 + ch * u - sh * v, self.y0 + sh * u + ch * v, self.hdg0 + k0 * ds + 0.5 * c * ds * ds, k0 + c * ds

    def local(self, ds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        k0, c = self.k0, self.rate
        t = ds[..., None] * self._nodes  # (..., P*G)
        theta = k0 * t + 0.5 * c * t * t
        u = (np.cos(theta) * self._weights).sum(axis=-1) * ds
        v = (np.sin(theta) * self._weights).sum(axis=-1) * ds
        return u, v, k0 * ds + 0.5 * c * ds * ds, k0 + c * ds


class _ArcLengthCurve(Geometry):
    """A curve given by a parameter p in [0, p_end]; s is mapped to p by arc length."""

    def _curve(self, p: Any) -> tuple[Any, Any, Any, Any, Any, Any]:
        """(u, v, du/dp, dv/dp, d2u/dp2, d2v/dp2) at parameters p (an array, or one float)."""
        raise NotImplementedError

    def _build_table(self, p_end: float, scale_to_length: bool) -> None:
        n = int(min(100_000, max(64, math.ceil(max(self.length, 1e-3) / _ARC_TABLE_STEP_M))))
        p = np.linspace(0.0, p_end, n + 1)
        dp = np.diff(p)
        nodes = p[:-1, None] + dp[:, None] * _GL_X[None, :]  # Gauss-Legendre per table interval
        _, _, du, dv, _, _ = self._curve(nodes)
        arc = np.concatenate([[0.0], np.cumsum((np.hypot(du, dv) * _GL_W).sum(axis=1) * dp)])
        _, _, du, dv, _, _ = self._curve(p)
        dp_ds = 1.0 / np.maximum(np.hypot(du, dv), 1e-12)
        if scale_to_length and arc[-1] > 0.0:
            scale = self.length / arc[-1]  # the curve's end is the geometry's end
            arc, dp_ds = arc * scale, dp_ds / scale
        self._p_table, self._s_table, self._dp_ds = p, arc, dp_ds
        self._s_list = arc.tolist()

    def point(self, ds: float) -> tuple[float, float, float, float]:
        s_tab = self._s_list
        ds = min(max(ds, 0.0), s_tab[-1])
        i = min(max(bisect.bisect_right(s_tab, ds) - 1, 0), len(s_tab) - 2)
        h = s_tab[i + 1] - s_tab[i]
        t = (ds - s_tab[i]) / h if h > 0 else 0.0
        t2, t3 = t * t, t * t * t
        pp = self._p_table
        p = (2 * t3 - 3 * t2 + 1) * float(pp[i]) + (t3 - 2 * t2 + t) * float(self._dp_ds[i]) * h
        p += (-2 * t3 + 3 * t2) * float(pp[i + 1]) + (t3 - t2) * float(self._dp_ds[i + 1]) * h
        u, v, du, dv, ddu, ddv = (float(c) for c in self._curve(p))
        sp2 = max(du * du + dv * dv, 1e-18)
        ch, sh = math.cos(self.hdg0), math.sin(self.hdg0)
        return (
            self.x0 + ch * u - sh * v,
            self.y0 + sh * u + ch * v,
            self.hdg0 + math.atan2(dv, du),
            (du * ddv - dv * ddu) / sp2**1.5,
        )

    def _param(self, ds: FloatArray) -> FloatArray:
        """p at arc length ds: cubic Hermite through the table (slopes dp/ds = 1/speed)."""
        s_tab = self._s_table
        ds = np.clip(ds, 0.0, s_tab[-1])
        i = np.clip(np.searchsorted(s_tab, ds, side="right") - 1, 0, len(s_tab) - 2)
        h = s_tab[i + 1] - s_tab[i]
        t = (ds - s_tab[i]) / np.where(h > 0, h, 1.0)
        t2, t3 = t * t, t * t * t
        p0, p1 = self._p_table[i], self._p_table[i + 1]
        m0, m1 = self._dp_ds[i] * h, self._dp_ds[i + 1] * h
        return (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * m1

    def local(self, ds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        p = self._param(ds)
        u, v, du, dv, ddu, ddv = self._curve(p)
        sp2 = np.maximum(du * du + dv * dv, 1e-18)
        kappa = (du * ddv - dv * ddu) / sp2**1.5
        return u, v, np.arctan2(dv, du), kappa


class Poly3(_ArcLengthCurve):
    """v = a + b u + c u^2 + d u^3 in the start frame (deprecated in 1.6, still common)."""

    kind = "poly3"

    def __init__(self, s0: float, x0: float, y0: float, hdg0: float, length: float, abcd: tuple[float, float, float, float]) -> None:
        super().__init__(s0, x0, y0, hdg0, length)
        self.abcd = abcd
        # arc length >= u, so the end parameter lies in [0, length]: tabulate there; s = length is the end
        self._build_table(max(length, 1e-9), scale_to_length=False)

    def _curve(self, p: Any) -> tuple[Any, Any, Any, Any, Any, Any]:
        a, b, c, d = self.abcd
        # plain arithmetic: works for arrays and for the scalar path alike
        return p, a + p * (b + p * (c + p * d)), 0 * p + 1.0, b + p * (2 * c + 3 * d * p), 0 * p, 2 * c + 6 * d * p


class ParamPoly3(_ArcLengthCurve):
    """u(p), v(p) cubics; pRange `arcLength` (p in [0, length]) or `normalized` (p in [0, 1])."""

    kind = "paramPoly3"

    def __init__(
        self,
        s0: float,
        x0: float,
        y0: float,
        hdg0: float,
        length: float,
        u_abcd: tuple[float, float, float, float],
        v_abcd: tuple[float, float, float, float],
        normalized: bool,
    ) -> None:
        super().__init__(s0, x0, y0, hdg0, length)
        self.u_abcd, self.v_abcd, self.normalized = u_abcd, v_abcd, normalized
        self._build_table(1.0 if normalized else length, scale_to_length=True)

    def _curve(self, p: Any) -> tuple[Any, Any, Any, Any, Any, Any]:
        au, bu, cu, du_ = self.u_abcd
        av, bv, cv, dv_ = self.v_abcd
        u = au + p * (bu + p * (cu + p * du_))
        v = av + p * (bv + p * (cv + p * dv_))
        return u, v, bu + p * (2 * cu + 3 * du_ * p), bv + p * (2 * cv + 3 * dv_ * p), 2 * cu + 6 * du_ * p, 2 * cv + 6 * dv_ * p


class ReferenceLine:
    """A road's chain of geometries, evaluated at absolute `s` (vectorised)."""

    def __init__(self, geometries: list[Geometry]) -> None:
        self.geometries = sorted(geometries, key=lambda g: g.s0)
        self._starts = np.array([g.s0 for g in self.geometries])
        self._starts_list = [g.s0 for g in self.geometries]

    def point(self, s: float) -> tuple[float, float, float, float]:
        """(x, y, heading, curvature) at one absolute s."""
        i = min(max(bisect.bisect_right(self._starts_list, s) - 1, 0), len(self.geometries) - 1)
        g = self.geometries[i]
        return g.point(s - g.s0)

    def evaluate(self, s: FloatArray | float) -> RefSample:
        s = np.atleast_1d(np.asarray(s, dtype=float))
        idx = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self.geometries) - 1)
        if len(self.geometries) == 1:
            g = self.geometries[0]
            return g.evaluate(s - g.s0)
        x, y, h, k = (np.empty_like(s) for _ in range(4))
        for gi in np.unique(idx):
            m = idx == gi
            g = self.geometries[int(gi)]
            r = g.evaluate(s[m] - g.s0)
            x[m], y[m], h[m], k[m] = r.x, r.y, r.hdg, r.kappa
        return RefSample(x, y, h, k)
