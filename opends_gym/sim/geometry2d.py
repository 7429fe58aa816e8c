"""Oriented boxes in the ground plane (x, z) and their overlap test.

Why: the fast backend detects collisions and trigger contacts in 2D; the same test
serves both backends' trigger volumes, so "hit a trigger" means the same thing for both.
Yaw follows the world convention (0 faces -Z, positive turns left); `hx` is the half
size along the box's local X (sideways), `hz` along its local Z (lengthwise).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..jit import inline, kernel


class Obb(NamedTuple):
    """An oriented box (a named tuple: the ego car's is built every physics step)."""

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
    return bool(_overlap(a.cx, a.cz, a.yaw, a.hx, a.hz, b.cx, b.cz, b.yaw, b.hx, b.hz))


@inline
def _separated(dx: float, dz: float, ux: float, uz: float, a: tuple[float, float, float, float, float, float],
               b: tuple[float, float, float, float, float, float]) -> bool:  # fmt: skip
    """Do the boxes' projections on axis (ux, uz) not overlap? (a, b: hx, hz, then the two local axes.)"""
    proj_a = a[0] * abs(a[2] * ux + a[3] * uz) + a[1] * abs(a[4] * ux + a[5] * uz)
    proj_b = b[0] * abs(b[2] * ux + b[3] * uz) + b[1] * abs(b[4] * ux + b[5] * uz)
    return abs(dx * ux + dz * uz) > proj_a + proj_b


@inline
def boxes_overlap(acx: float, acz: float, ayaw: float, ahx: float, ahz: float, bcx: float, bcz: float, byaw: float, bhx: float,
                  bhz: float) -> bool:  # fmt: skip
    """The separating-axis test on plain numbers (compiled; the Python `obb_overlap` and the
    traffic and trigger kernels share it)."""
    dx, dz = bcx - acx, bcz - acz
    # quick reject on bounding circles
    ra = ahx * ahx + ahz * ahz
    rb = bhx * bhx + bhz * bhz
    d2 = dx * dx + dz * dz
    if d2 > ra + rb + 2.0 * math.sqrt(ra * rb):
        return False
    ca, sa = math.cos(ayaw), math.sin(ayaw)
    cb, sb = math.cos(byaw), math.sin(byaw)
    a = (ahx, ahz, ca, -sa, sa, ca)
    b = (bhx, bhz, cb, -sb, sb, cb)
    for ux, uz in ((ca, -sa), (sa, ca), (cb, -sb), (sb, cb)):  # noqa: SIM110  (numba compiles no generators)
        if _separated(dx, dz, ux, uz, a, b):
            return False
    return True


@kernel
def _overlap(acx: float, acz: float, ayaw: float, ahx: float, ahz: float, bcx: float, bcz: float, byaw: float, bhx: float,
             bhz: float) -> bool:  # fmt: skip
    return boxes_overlap(acx, acz, ayaw, ahx, ahz, bcx, bcz, byaw, bhx, bhz)  # (inlined helpers are not callable from Python)
