"""Mean deviation from an ideal track, exactly as OpenDS's Drive Analyzer computes it.

Why: OpenDS reports how far a drive strayed from the task's `idealTrack` as an area per
length; numbers from our analyzer must be the numbers OpenDS prints. This follows
`eu.opends.analyzer.IdealLine` (constructor, `getHalfwayVector`, `getPointOnLine`),
`DeviationQuadrangle.getArea` and `DeviationComputer.getIdealLines`, with Java's float
(binary32) arithmetic where OpenDS uses `float` and Java2D's double geometry
(`Line2D.relativeCCW`, `ptSegDist`, `ptLineDist`) where OpenDS uses `Line2D.Float`:

* a track needs >= 3 ideal points; only the inner points IP(1)..IP(n-2) are processed;
* at IP(i) the cross line is the bisector of the angle (IP(i-1), IP(i), IP(i+1)) (the
  perpendicular of IP(i-1)->IP(i+1) when the two directions are exactly opposite), a
  segment of half-length roadWidth/2 (roadWidth default 15 m);
* the driven point on it: the recorded positions are scanned from the first one on,
  skipping those more than 10 m from the cross *segment*; a position on the line is taken
  as it is; otherwise the scan stops as soon as positions on both sides were seen, and
  the last one seen on each side is interpolated by their distances from the (infinite)
  line. No positions on both sides: IP(i) is missing;
* the area of the quadrangle (previous driven point, this driven point, IP(i), IP(i-1)) is
  added (two triangles where the driven segment crosses IP(i-1)->IP(i)); the previous
  driven point starts as IP(0) and skips missing points, so gaps are bridged;
* the length adds |IP(i) IP(i+1)| per processed point, plus |IP(0) IP(1)| when the status
  is Complete or IncompleteEnd; mean deviation = area / length (`DriveAnalyzer`).

A constant offset d on n equally spaced ideal points therefore gives d (n - 2.5) / (n - 1):
the first piece is a triangle and the last segment has length but no area.
Positions are ground-plane (x, z) pairs in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

MAX_DISTANCE_M = 10.0  # IdealLine.MAX_DISTANCE: positions farther from the cross segment are ignored
DEFAULT_ROAD_WIDTH_M = 15.0  # IdealLine.roadWidth when the idealTrack gives none
CELL_M = 20.0  # bucket size for finding recorded positions near a cross line (speed only)

F32 = np.float32


class Completeness(str, Enum):
    """`IdealLine.IdealLineStatus`; str() and format() give the value (as
    StrEnum would, which Python 3.10 lacks)."""

    def __str__(self) -> str:
        return str(self.value)

    def __format__(self, spec: str) -> str:
        return format(str(self.value), spec)

    COMPLETE = "Complete"
    INCOMPLETE_BEGINNING = "IncompleteBeginning"
    INCOMPLETE_END = "IncompleteEnd"
    INCOMPLETE_BEGINNING_AND_END = "IncompleteBeginningAndEnd"
    INCOMPLETE = "Incomplete"
    UNAVAILABLE = "Unavailable"


@dataclass(frozen=True)
class DeviationResult:
    mean_deviation_m: float  # NaN when unavailable
    area_m2: float
    length_m: float
    status: Completeness
    driven_points: tuple[tuple[float, float] | None, ...]  # per ideal point (None: first, last, missing)
    problem: str = ""  # why OpenDS would drop the whole line (DeviationComputer prints it)

    @property
    def available(self) -> bool:
        return self.status is not Completeness.UNAVAILABLE


# ------------------------------------------------------------------ Java2D (double) geometry
def relative_ccw(x1: float, y1: float, x2: float, y2: float, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """`Line2D.relativeCCW` for many points: -1, 0 (on the segment) or 1."""
    x2, y2 = x2 - x1, y2 - y1
    px, py = px - x1, py - y1
    ccw = px * y2 - py * x2
    on = ccw == 0.0
    if np.any(on):
        along = px * x2 + py * y2
        beyond = (px - x2) * x2 + (py - y2) * y2
        ccw = np.where(on, np.where(along > 0.0, np.maximum(beyond, 0.0), along), ccw)
    return np.sign(ccw).astype(np.int8)


def pt_seg_dist(x1: float, y1: float, x2: float, y2: float, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """`Line2D.ptSegDist`: distance to the segment."""
    x2, y2 = x2 - x1, y2 - y1
    px, py = px - x1, py - y1
    dot = px * x2 + py * y2
    bx, by = x2 - px, y2 - py
    dot2 = bx * x2 + by * y2
    len2 = x2 * x2 + y2 * y2
    with np.errstate(invalid="ignore", divide="ignore"):
        proj = np.where((dot <= 0.0) | (dot2 <= 0.0), 0.0, dot2 * dot2 / len2)
    qx, qy = np.where(dot <= 0.0, px, bx), np.where(dot <= 0.0, py, by)
    return np.sqrt(np.maximum(qx * qx + qy * qy - proj, 0.0))


def pt_line_dist(x1: float, y1: float, x2: float, y2: float, px: float, py: float) -> float:
    """`Line2D.ptLineDist`: distance to the infinite line."""
    x2, y2 = x2 - x1, y2 - y1
    px, py = px - x1, py - y1
    dot = px * x2 + py * y2
    with np.errstate(invalid="ignore", divide="ignore"):
        proj = dot * dot / (x2 * x2 + y2 * y2)
    return math.sqrt(max(px * px + py * py - proj, 0.0))


# ------------------------------------------------------------------ jME (float) vectors
def _normalize(x: np.float32, y: np.float32) -> tuple[np.float32, np.float32]:
    """`Vector2f.normalize`: divide by the float length (unchanged when it is 0)."""
    n = np.sqrt(F32(x * x + y * y))
    return (x / n, y / n) if n != 0 else (x, y)


def halfway_line(prev: np.ndarray, curr: np.ndarray, nxt: np.ndarray, road_width_m: float) -> tuple[float, float, float, float]:
    """`IdealLine.getHalfwayVector`: the cross segment (x1, z1, x2, z2) at `curr`.

    Raises ValueError for three identical points (OpenDS then drops the whole line)."""
    b, a, c = (np.asarray(p, dtype=F32) for p in (prev, curr, nxt))
    abx, aby = _normalize(b[0] - a[0], b[1] - a[1])
    acx, acy = _normalize(c[0] - a[0], c[1] - a[1])
    hx, hy = F32(abx + acx), F32(aby + acy)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if hx == 0 and hy == 0 and not (np.signbit(hx) or np.signbit(hy)):  # Vector2f.equals(0, 0): opposite directions
            bcx, bcy = _normalize(c[0] - b[0], c[1] - b[1])  # perpendicular to B->C
            if bcx != 0:
                hx, hy = F32(-bcy / bcx), F32(1.0)
            elif bcy != 0:
                hx, hy = F32(1.0), F32(-bcx / bcy)
            else:
                raise ValueError("identical ideal points given")
        hx, hy = _normalize(hx, hy)
        half = F32(F32(road_width_m) / F32(2.0))
        hx, hy = F32(hx * half), F32(hy * half)
    return float(F32(a[0] + hx)), float(F32(a[1] + hy)), float(F32(a[0] - hx)), float(F32(a[1] - hy))


def point_on_line(line: tuple[float, float, float, float], px: np.ndarray, pz: np.ndarray) -> tuple[np.float32, np.float32] | None:
    """`IdealLine.getPointOnLine`: the driven point on the cross segment, or None (missing)."""
    x1, y1, x2, y2 = line
    near = np.flatnonzero(pt_seg_dist(x1, y1, x2, y2, px, pz) <= MAX_DISTANCE_M)
    if len(near) == 0:
        return None
    side = relative_ccw(x1, y1, x2, y2, px[near], pz[near])
    left, right, on = np.flatnonzero(side == -1), np.flatnonzero(side == 1), np.flatnonzero(side == 0)
    stop = max(left[0], right[0]) if len(left) and len(right) else None
    if len(on) and (stop is None or on[0] < stop):
        k = near[on[0]]
        return F32(px[k]), F32(pz[k])
    if stop is None:
        return None
    li, ri = near[left[left <= stop][-1]], near[right[right <= stop][-1]]
    dl = F32(pt_line_dist(x1, y1, x2, y2, float(px[li]), float(pz[li])))
    dr = F32(pt_line_dist(x1, y1, x2, y2, float(px[ri]), float(pz[ri])))
    with np.errstate(invalid="ignore", divide="ignore"):
        s = F32(dl + dr)
        wl, wr = F32(dr / s), F32(dl / s)
        return F32(F32(F32(px[li]) * wl) + F32(F32(px[ri]) * wr)), F32(F32(F32(pz[li]) * wl) + F32(F32(pz[ri]) * wr))


class RecordedCells:
    """Recorded positions bucketed in `CELL_M` squares: a cross line scans only the positions
    that can be within 10 m of it, still in recording order (same answer, not O(n) per point).
    Non-finite positions are left out."""

    def __init__(self, px: np.ndarray, pz: np.ndarray) -> None:
        idx = np.flatnonzero(np.isfinite(px) & np.isfinite(pz))
        cells = np.column_stack([np.floor(px[idx] / CELL_M), np.floor(pz[idx] / CELL_M)]).astype(np.int64)
        self.keys, inverse = np.unique(cells, axis=0, return_inverse=True)
        order = np.argsort(inverse.ravel(), kind="stable")
        self.members = np.split(idx[order], np.cumsum(np.bincount(inverse.ravel(), minlength=len(self.keys)))[:-1])

    def near(self, line: tuple[float, float, float, float]) -> np.ndarray:
        """Indices (ascending) of the positions in cells reaching within MAX_DISTANCE_M of the segment's box."""
        x1, y1, x2, y2 = line
        lo = np.floor((np.array([min(x1, x2), min(y1, y2)]) - MAX_DISTANCE_M) / CELL_M)
        hi = np.floor((np.array([max(x1, x2), max(y1, y2)]) + MAX_DISTANCE_M) / CELL_M)
        hit = np.flatnonzero(np.all((self.keys >= lo) & (self.keys <= hi), axis=1))
        if len(hit) == 0:
            return np.zeros(0, dtype=np.int64)
        return np.sort(np.concatenate([self.members[k] for k in hit]))


def _tri2(ax: np.float32, ay: np.float32, bx: np.float32, by: np.float32) -> np.float32:
    return F32(F32(0.5) * abs(F32(F32(ax * by) - F32(ay * bx))))


def quad_area(wp0: np.ndarray, wp1: np.ndarray, ip1: np.ndarray, ip0: np.ndarray) -> float:
    """`DeviationQuadrangle.getArea` of (WP0, WP1, IP1, IP0): the shoelace area, or, where WP0
    and WP1 lie on opposite sides of IP0->IP1, the two triangles meeting at the crossing."""
    w0, w1, i1, i0 = (np.asarray(p, dtype=F32) for p in (wp0, wp1, ip1, ip0))
    x1, y1, x2, y2 = float(i0[0]), float(i0[1]), float(i1[0]), float(i1[1])
    s0, s1 = (int(relative_ccw(x1, y1, x2, y2, np.array([float(w[0])]), np.array([float(w[1])]))[0]) for w in (w0, w1))
    if s0 * s1 == -1:
        d0 = F32(pt_line_dist(x1, y1, x2, y2, float(w0[0]), float(w0[1])))
        d1 = F32(pt_line_dist(x1, y1, x2, y2, float(w1[0]), float(w1[1])))
        s = F32(d0 + d1)
        with np.errstate(divide="ignore", invalid="ignore"):  # d0 = d1 = 0 in float32: NaN, as Java's float division
            x = F32(F32(w0[0] * F32(d1 / s)) + F32(w1[0] * F32(d0 / s)))
            y = F32(F32(w0[1] * F32(d1 / s)) + F32(w1[1] * F32(d0 / s)))
        a1 = _tri2(F32(w0[0] - x), F32(w0[1] - y), F32(i0[0] - x), F32(i0[1] - y))
        a2 = _tri2(F32(w1[0] - x), F32(w1[1] - y), F32(i1[0] - x), F32(i1[1] - y))
        return float(F32(a1 + a2))
    p = (w0, w1, i1, i0)
    t = F32(F32(F32(p[0][1] - p[2][1]) * F32(p[3][0] - p[1][0])) + F32(F32(p[1][1] - p[3][1]) * F32(p[0][0] - p[2][0])))
    return float(F32(F32(0.5) * abs(t)))


def _dist(a: np.ndarray, b: np.ndarray) -> np.float32:
    """`Vector2f.distance` in float."""
    dx, dy = F32(a[0] - b[0]), F32(a[1] - b[1])
    return np.sqrt(F32(F32(dx * dx) + F32(dy * dy)))


def _next_status(status: Completeness, found: bool, processed: int) -> Completeness:
    """The status update of the `IdealLine` constructor after one inner ideal point."""
    C = Completeness
    if found:
        return C.INCOMPLETE if status in (C.INCOMPLETE_END, C.INCOMPLETE_BEGINNING_AND_END) else status
    if status is C.INCOMPLETE:
        return status
    if processed == 0:
        return C.INCOMPLETE_BEGINNING
    if status in (C.INCOMPLETE_BEGINNING, C.INCOMPLETE_BEGINNING_AND_END):
        return C.INCOMPLETE_BEGINNING_AND_END
    return C.INCOMPLETE_END


def _unavailable(n: int, problem: str) -> DeviationResult:
    return DeviationResult(math.nan, 0.0, 0.0, Completeness.UNAVAILABLE, (None,) * n, problem)


def mean_deviation(
    driven: np.ndarray | list[tuple[float, float]],
    ideal: np.ndarray | list[tuple[float, float]],
    road_width_m: float = DEFAULT_ROAD_WIDTH_M,
) -> DeviationResult:
    """Mean deviation (m) of a driven path from an ideal track, as OpenDS's `IdealLine`.

    `driven` and `ideal` are sequences of (x, z) ground positions, the driven ones in
    recording order. A track OpenDS refuses (fewer than 3 points, three identical points)
    comes back Unavailable with the reason in `problem`.
    """
    path = np.asarray(driven, dtype=float).reshape(-1, 2).astype(F32).astype(float)  # Vector3f floats
    ip = np.asarray(ideal, dtype=float).reshape(-1, 2).astype(F32)
    n = len(ip)
    if n < 3:
        return _unavailable(n, "not enough ideal points given (IdealLine needs 3)")
    px, pz = np.ascontiguousarray(path[:, 0]), np.ascontiguousarray(path[:, 1])
    cells = RecordedCells(px, pz)
    area, length = F32(0.0), F32(0.0)
    status = Completeness.COMPLETE
    prev_wp: tuple[np.float32, np.float32] = (ip[0][0], ip[0][1])
    points: list[tuple[float, float] | None] = [None] * n
    processed = 0
    for i in range(1, n - 1):
        try:
            line = halfway_line(ip[i - 1], ip[i], ip[i + 1], road_width_m)
        except ValueError as e:
            return _unavailable(n, str(e))
        near = cells.near(line)
        wp = point_on_line(line, px[near], pz[near]) if len(near) else None
        if wp is not None:
            area = F32(area + F32(quad_area(np.array(prev_wp), np.array(wp), ip[i], ip[i - 1])))
            length = F32(length + _dist(ip[i], ip[i + 1]))
            points[i] = (float(wp[0]), float(wp[1]))
            prev_wp = wp
        status = _next_status(status, wp is not None, processed)
        processed += wp is not None
    if processed == 0:
        status = Completeness.UNAVAILABLE
    if status in (Completeness.COMPLETE, Completeness.INCOMPLETE_END):
        length = F32(length + _dist(ip[0], ip[1]))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = float(F32(area / length)) if status is not Completeness.UNAVAILABLE else math.nan
    return DeviationResult(mean, float(area), float(length), status, tuple(points))
