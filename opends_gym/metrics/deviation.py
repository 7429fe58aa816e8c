"""Mean deviation from an ideal track, with OpenDS's Drive Analyzer algorithm.

Why: OpenDS reports how far a drive strayed from the task's `idealTrack` as an area per
length. We reproduce `eu.opends.analyzer.IdealLine` as described in OPENDS.md section 3:

* at every ideal point IP(i) a cross line is built: the angle bisector of the two
  neighbouring segments (the perpendicular where they are collinear, and at the two end
  points), of half-length roadWidth/2;
* the driven position on that line is interpolated between the recorded samples on
  either side of it; samples more than 10 m from the line are ignored;
* for consecutive found points the area of the quadrilateral (prev driven, current
  driven, IP(i), IP(i-1)) is added (as two triangles where the driven path crosses the
  ideal line, so crossing never cancels area);
* mean deviation = total area / length of the ideal line over the covered segments.

Positions are ground-plane (x, z) pairs in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

MAX_SAMPLE_DISTANCE_M = 10.0


class Completeness(str, Enum):
    """OpenDS Drive Analyzer's completeness status; str() and format() give the value (as
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
    driven_points: tuple[tuple[float, float] | None, ...]  # crossing per ideal point

    @property
    def available(self) -> bool:
        return self.status is not Completeness.UNAVAILABLE


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.hypot(v[0], v[1]))
    return v / n if n > 0 else v


def cross_lines(ideal: np.ndarray) -> np.ndarray:
    """Unit direction of the cross line at every ideal point (shape (n, 2))."""
    n = len(ideal)
    dirs = np.zeros((n, 2))
    for i in range(n):
        if i == 0:
            t = _unit(ideal[1] - ideal[0])
        elif i == n - 1:
            t = _unit(ideal[-1] - ideal[-2])
        else:
            a = _unit(ideal[i] - ideal[i - 1])
            b = _unit(ideal[i + 1] - ideal[i])
            t = _unit(a + b)
            if not np.any(t):  # reversal: fall back to the incoming direction
                t = a
        # the bisector of the corner is perpendicular to the mean tangent
        dirs[i] = (-t[1], t[0])
    return dirs


def _crossing(path: np.ndarray, centre: np.ndarray, direction: np.ndarray, half_len: float, start: int) -> tuple[np.ndarray, int] | None:
    """First crossing of the driven path (from sample `start` on) with the cross line."""
    normal = np.array([direction[1], -direction[0]])  # along the track
    rel = path - centre
    side = rel @ normal  # signed distance to the (infinite) cross line
    along = rel @ direction
    near = np.abs(side) <= MAX_SAMPLE_DISTANCE_M
    for k in range(max(start, 0), len(path) - 1):
        if not (near[k] and near[k + 1]):
            continue
        s0, s1 = side[k], side[k + 1]
        if s0 == 0.0 or s0 * s1 < 0.0 or (s1 == 0.0 and s0 != 0.0):
            f = 0.0 if s0 == s1 else s0 / (s0 - s1)
            a = along[k] + f * (along[k + 1] - along[k])
            if abs(a) <= half_len:
                return centre + a * direction, k
    return None


def _tri(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    return 0.5 * abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))


def _segment_intersection(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray | None:
    r = p2 - p1
    s = q2 - q1
    denom = r[0] * s[1] - r[1] * s[0]
    if denom == 0.0:
        return None
    qp = q1 - p1
    t = (qp[0] * s[1] - qp[1] * s[0]) / denom
    u = (qp[0] * r[1] - qp[1] * r[0]) / denom
    if 0.0 < t < 1.0 and 0.0 < u < 1.0:
        return p1 + t * r
    return None


def quad_area(d0: np.ndarray, d1: np.ndarray, i1: np.ndarray, i0: np.ndarray) -> float:
    """Area between driven segment d0->d1 and ideal segment i0->i1 (crossings split it)."""
    x = _segment_intersection(d0, d1, i0, i1)
    if x is not None:
        return _tri(i0, d0, x) + _tri(x, d1, i1)
    return _tri(d0, d1, i1) + _tri(d0, i1, i0)


def _status(found: list[bool]) -> Completeness:
    idx = [i for i, f in enumerate(found) if f]
    if len(idx) < 2:
        return Completeness.UNAVAILABLE
    first, last = idx[0], idx[-1]
    if any(not f for f in found[first : last + 1]):
        return Completeness.INCOMPLETE
    begin, end = first > 0, last < len(found) - 1
    if begin and end:
        return Completeness.INCOMPLETE_BEGINNING_AND_END
    if begin:
        return Completeness.INCOMPLETE_BEGINNING
    if end:
        return Completeness.INCOMPLETE_END
    return Completeness.COMPLETE


def mean_deviation(
    driven: np.ndarray | list[tuple[float, float]], ideal: np.ndarray | list[tuple[float, float]], road_width_m: float = 15.0
) -> DeviationResult:
    """Mean deviation (m) of a driven path from an ideal track, OpenDS style.

    `driven` and `ideal` are sequences of (x, z) ground positions in driving order.
    """
    path = np.asarray(driven, dtype=float).reshape(-1, 2)
    ip = np.asarray(ideal, dtype=float).reshape(-1, 2)
    if len(ip) < 2:
        raise ValueError("an ideal track needs at least two points")
    dirs = cross_lines(ip)
    half = 0.5 * road_width_m
    points: list[np.ndarray | None] = []
    start = 0
    for i in range(len(ip)):
        hit = _crossing(path, ip[i], dirs[i], half, start) if len(path) >= 2 else None
        if hit is None:
            points.append(None)
        else:
            points.append(hit[0])
            start = hit[1]
    area = 0.0
    length = 0.0
    for i in range(1, len(ip)):
        a, b = points[i - 1], points[i]
        if a is None or b is None:
            continue
        area += quad_area(a, b, ip[i], ip[i - 1])
        length += float(math.hypot(*(ip[i] - ip[i - 1])))
    status = _status([p is not None for p in points])
    mean = area / length if length > 0 and status is not Completeness.UNAVAILABLE else math.nan
    return DeviationResult(
        mean_deviation_m=mean,
        area_m2=area,
        length_m=length,
        status=status,
        driven_points=tuple(None if p is None else (float(p[0]), float(p[1])) for p in points),
    )
