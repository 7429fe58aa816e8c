"""Pinhole cameras: world-to-view transform, projection to pixels, near-plane clipping.

Why: the driver view, chase view, mirrors and multi-screen rigs are the same maths with
different poses. World frame: metres, Y up, yaw 0 looks along -Z, positive yaw turns left,
positive pitch looks up. A mirror camera flips the image left-right (as OpenDS negates
its projection matrix's m00).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

OPENDS_VFOV_DEG = 30.5  # OpenDS's single-screen camera (setFrustumPerspective(30.5, ...))
OPENDS_NEAR_M = 1.0
OPENDS_FAR_M = 2000.0


@dataclass(frozen=True)
class Camera:
    x: float
    y: float
    z: float
    yaw: float
    pitch: float = 0.0
    vfov_rad: float = math.radians(OPENDS_VFOV_DEG)
    hfov_rad: float | None = None  # when set, the horizontal field of view fixes the focal length
    near: float = 0.3
    far: float = OPENDS_FAR_M
    mirror: bool = False

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors in world coordinates."""
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        f0 = np.array([-sy, 0.0, -cy])
        r = np.array([cy, 0.0, -sy])
        up0 = np.array([0.0, 1.0, 0.0])
        return r, -sp * f0 + cp * up0, cp * f0 + sp * up0

    def focal_px(self, width: int, height: int) -> float:
        if self.hfov_rad is not None:
            return 0.5 * width / math.tan(0.5 * self.hfov_rad)
        return 0.5 * height / math.tan(0.5 * self.vfov_rad)

    def to_view(self, pts: np.ndarray) -> np.ndarray:
        """World points (..., 3) to view coordinates (x right, y up, z depth ahead)."""
        r, u, f = self.basis()
        m = np.stack([r, u, f], axis=1)
        return (pts - np.array([self.x, self.y, self.z])) @ m

    def project(self, view: np.ndarray, width: int, height: int) -> np.ndarray:
        """View points with depth > 0 to pixel coordinates (..., 2)."""
        fpx = self.focal_px(width, height)
        z = view[..., 2]
        sx = fpx * view[..., 0] / z
        if self.mirror:
            sx = -sx
        return np.stack([0.5 * width + sx, 0.5 * height - fpx * view[..., 1] / z], axis=-1)

    def ground_row_depths(self, width: int, height: int, eye_height_m: float) -> np.ndarray:
        """Per screen row: depth of the flat ground seen there (inf where the row shows sky)."""
        fpx = self.focal_px(width, height)
        a = (0.5 * height - (np.arange(height) + 0.5)) / fpx
        dy = math.sin(self.pitch) + a * math.cos(self.pitch)  # world-up component of the row's ray
        with np.errstate(divide="ignore"):
            depth = np.where(dy < -1e-9, eye_height_m / -dy, np.inf)
        return depth


def clip_near(poly: np.ndarray, near: float) -> np.ndarray:
    """Sutherland-Hodgman clip of a view-space polygon (n, 3) against depth >= near."""
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ina, inb = a[2] >= near, b[2] >= near
        if ina:
            out.append(a)
        if ina != inb:
            t = (near - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.asarray(out).reshape(-1, 3)
