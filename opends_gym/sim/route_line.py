"""Lines in the ground plane (x, z) for the ego's road: arc length, the foot point of a
position, headings, and the curve that joins a start pose to a line.

Why: `lane_sources` builds the ego's road from several kinds of task data; they all end up
as a polyline the start pose has to be put on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..task.model_task import Pose

JOIN_MAX_M = 120.0  # a road further than this from the start is not the ego's
ON_LINE_M = 1.0  # closer than this to the line: no connector
SAMPLE_M = 1.0  # spacing of the connector's samples
MIN_AHEAD_M = 100.0  # a line that ends sooner than this after the start is not the ego's road


def arc_lengths(points: np.ndarray) -> np.ndarray:
    d = np.hypot(np.diff(points[:, 0]), np.diff(points[:, 1]))
    return np.concatenate([[0.0], np.cumsum(d)])


def dedupe(points: np.ndarray) -> np.ndarray:
    """Drop points that repeat the previous one (a joined route repeats its joints)."""
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.hypot(np.diff(points[:, 0]), np.diff(points[:, 1])) > 1e-6
    return points[keep]


def project(points: np.ndarray, x: float, z: float) -> tuple[float, float, int, float]:
    """(distance from the line, signed offset + left, segment index, arc length) of (x, z)."""
    a = points[:-1]
    d = points[1:] - a
    L2 = np.maximum(d[:, 0] ** 2 + d[:, 1] ** 2, 1e-12)
    t = np.clip(((x - a[:, 0]) * d[:, 0] + (z - a[:, 1]) * d[:, 1]) / L2, 0.0, 1.0)
    px, pz = a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1]
    dist2 = (px - x) ** 2 + (pz - z) ** 2
    k = int(np.argmin(dist2))
    L = math.sqrt(float(L2[k]))
    lx, lz = d[k, 1] / L, -d[k, 0] / L  # left of travel (dx, dz) is (dz, -dx): forward -Z, left -X
    offset = (x - px[k]) * lx + (z - pz[k]) * lz
    s = float(arc_lengths(points[: k + 1])[-1]) + float(t[k]) * L if k else float(t[k]) * L
    return math.sqrt(float(dist2[k])), float(offset), k, s


def heading_of(points: np.ndarray, k: int) -> float:
    """Yaw (0 faces -Z, + turns left) of segment k."""
    dx, dz = points[k + 1] - points[k]
    return math.atan2(-float(dx), -float(dz))


def hermite(p0: tuple[float, float], yaw0: float, p1: tuple[float, float], yaw1: float) -> np.ndarray:
    """A cubic Hermite curve from p0 (heading yaw0) to p1 (heading yaw1), ~1 m samples."""
    chord = math.hypot(p1[0] - p0[0], p1[1] - p0[1])
    m = 1.2 * chord  # tangent length: a U-turn stays a rounded loop, a lane change an S
    t0 = np.array([-math.sin(yaw0), -math.cos(yaw0)]) * m
    t1 = np.array([-math.sin(yaw1), -math.cos(yaw1)]) * m
    n = max(8, int(math.ceil(2.0 * chord / SAMPLE_M)))
    u = np.linspace(0.0, 1.0, n + 1)[:, None]
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    out: np.ndarray = h00 * np.asarray(p0) + h10 * t0 + h01 * np.asarray(p1) + h11 * t1
    return out


def wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def join_start(start: Pose, line: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The line from the start pose on: the line itself from the start's foot point when the
    start lies on it, else a connector to a point ahead on it. None when too far away."""
    x0, z0 = start.position_m[0], start.position_m[2]
    dist, _, k, s0 = project(line, x0, z0)
    if dist > JOIN_MAX_M:
        return None
    arc = arc_lengths(line)
    if dist <= ON_LINE_M:
        first = max(0, k - 10)  # keep a little of the line behind the start
        return line[first:], 0.0
    along = math.cos(wrap(heading_of(line, k) - start.yaw_rad))
    advance = 0.5 * (1.0 + along) * max(30.0, 2.0 * dist)  # ahead along the line: none for a U-turn
    sj = min(s0 + advance, float(arc[-1]))
    j = min(int(np.searchsorted(arc, sj, side="right")), len(line) - 1)
    pj = (float(line[j, 0]), float(line[j, 1]))
    yaw_j = heading_of(line, min(j, len(line) - 2))
    conn = hermite((x0, z0), start.yaw_rad, pj, yaw_j)
    joined = dedupe(np.vstack([conn, line[j + 1 :]]))
    return joined, float(arc_lengths(conn)[-1])


def foot_point(line: np.ndarray, x: float, z: float) -> tuple[float, float]:
    a = line[:-1]
    d = line[1:] - a
    L2 = np.maximum(d[:, 0] ** 2 + d[:, 1] ** 2, 1e-12)
    t = np.clip(((x - a[:, 0]) * d[:, 0] + (z - a[:, 1]) * d[:, 1]) / L2, 0.0, 1.0)
    px, pz = a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1]
    k = int(np.argmin((px - x) ** 2 + (pz - z) ** 2))
    return float(px[k]), float(pz[k])


def best_match(start: Pose, lines: Sequence[np.ndarray], min_ahead_m: float = MIN_AHEAD_M) -> tuple[int, float] | None:
    """The line the start pose belongs to: near, heading its way and not ending at once
    (cost in metres)."""
    x0, z0 = start.position_m[0], start.position_m[2]
    best: tuple[float, int] | None = None
    for i, line in enumerate(lines):
        dist, _, k, s = project(line, x0, z0)
        if dist > JOIN_MAX_M or float(arc_lengths(line)[-1]) - s < min_ahead_m:
            continue
        along = math.cos(wrap(heading_of(line, k) - start.yaw_rad))
        cost = dist + (20.0 * (1.0 - along) if dist > ON_LINE_M else 40.0 * (1.0 - along))
        if best is None or cost < best[0] - 1e-9:
            best = (cost, i)
    return None if best is None else (best[1], best[0])
