"""Oriented boxes in the ground plane (x, z) and their overlap test.

Why: the fast backend detects collisions and trigger contacts in 2D; the same test
serves both backends' trigger volumes, so "hit a trigger" means the same thing for both.
Yaw follows the world convention (0 faces -Z, positive turns left); `hx` is the half
size along the box's local X (sideways), `hz` along its local Z (lengthwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Obb:
    cx: float
    cz: float
    yaw: float
    hx: float
    hz: float

    def axes(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Local X and Z axes in world (x, z). Local -Z is forward."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (c, -s), (s, c)

    def corners(self) -> list[tuple[float, float]]:
        (ax, az), (bx, bz) = self.axes()
        out = []
        for sx, sz in ((1, 1), (1, -1), (-1, -1), (-1, 1)):
            out.append((self.cx + sx * self.hx * ax + sz * self.hz * bx, self.cz + sx * self.hx * az + sz * self.hz * bz))
        return out


def obb_overlap(a: Obb, b: Obb) -> bool:
    """Separating-axis test for two oriented rectangles."""
    dx, dz = b.cx - a.cx, b.cz - a.cz
    # quick reject on bounding circles
    ra = a.hx * a.hx + a.hz * a.hz
    rb = b.hx * b.hx + b.hz * b.hz
    d2 = dx * dx + dz * dz
    if d2 > ra + rb + 2.0 * math.sqrt(ra * rb):
        return False
    a_axes = a.axes()
    b_axes = b.axes()
    for ux, uz in (*a_axes, *b_axes):
        proj_a = a.hx * abs(a_axes[0][0] * ux + a_axes[0][1] * uz) + a.hz * abs(a_axes[1][0] * ux + a_axes[1][1] * uz)
        proj_b = b.hx * abs(b_axes[0][0] * ux + b_axes[0][1] * uz) + b.hz * abs(b_axes[1][0] * ux + b_axes[1][1] * uz)
        if abs(dx * ux + dz * uz) > proj_a + proj_b:
            return False
    return True
