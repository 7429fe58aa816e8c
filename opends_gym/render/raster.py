"""Painter's-algorithm rasteriser: world quads -> fogged, clipped, sorted pygame polygons.

Why: no GL context exists on a headless server, yet the driver view must be 3D and fast.
All transforms, culling and fog run vectorised in numpy over every quad of the frame;
only the final `pygame.draw.polygon` calls loop in Python. Quads are ordered by layer
(ground, markings, objects), then far to near by their group's distance, then by their
order inside the group; the few quads that cross the near plane are clipped one by one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _pg
from .camera import Camera, clip_near

LAYER_GROUND, LAYER_MARKING, LAYER_OBJECT = 0, 1, 2
SUN = np.array([0.45, 0.8, 0.38]) / np.linalg.norm([0.45, 0.8, 0.38])

# box faces over the corner order (-hx,-hz), (+hx,-hz), (+hx,+hz), (-hx,+hz): top, front, right, rear, left
_SIDE_NORMALS_LOCAL = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])


@dataclass
class QuadBatch:
    """Quads (N, 4, 3) with colours, normals (zero = never culled), layer, group centre and order."""

    quads: list[np.ndarray] = field(default_factory=list)
    colors: list[np.ndarray] = field(default_factory=list)
    normals: list[np.ndarray] = field(default_factory=list)
    layers: list[np.ndarray] = field(default_factory=list)
    centres: list[np.ndarray] = field(default_factory=list)
    orders: list[np.ndarray] = field(default_factory=list)
    wire: list[np.ndarray] = field(default_factory=list)
    labels: dict[int, str] = field(default_factory=dict)
    count: int = 0

    def add(
        self,
        quads: np.ndarray,
        colors: np.ndarray,
        layer: int,
        normals: np.ndarray | None = None,
        centres: np.ndarray | None = None,
        orders: np.ndarray | None = None,
        wire: np.ndarray | None = None,
    ) -> int:
        n = len(quads)
        if n == 0:
            return self.count
        self.quads.append(quads)
        self.colors.append(np.broadcast_to(np.asarray(colors, float), (n, 3)))
        self.normals.append(np.zeros((n, 3)) if normals is None else normals)
        self.layers.append(np.full(n, layer))
        self.centres.append(quads.mean(axis=1) if centres is None else centres)
        self.orders.append(np.zeros(n) if orders is None else orders)
        self.wire.append(np.zeros(n, bool) if wire is None else wire)
        first = self.count
        self.count += n
        return first


def ground_quads(xz: np.ndarray, y: float) -> np.ndarray:
    """(N, 4, 2) ground quads at height y as (N, 4, 3)."""
    return np.concatenate([xz[..., :1], np.full(xz.shape[:-1] + (1,), y), xz[..., 1:]], axis=-1)


def line_quads(lines: np.ndarray, half_w: np.ndarray, y: float) -> np.ndarray:
    """Painted lines (x0, z0, x1, z1) as flat quads of their width, lifted a little above the road."""
    p0, p1 = lines[:, :2], lines[:, 2:]
    d = p1 - p0
    n = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    off = n * half_w[:, None]
    xz = np.stack([p0 + off, p1 + off, p1 - off, p0 - off], axis=1)
    return ground_quads(xz, y)


def add_boxes(batch: QuadBatch, rows: np.ndarray, labels: dict[int, str]) -> None:
    """Boxes (rows of `scene.BoxRows`) as five shaded faces each (the bottom is never seen)."""
    if not len(rows):
        return
    cx, cz, yaw, y0, y1, hx, hz = (rows[:, i] for i in range(7))
    c, s = np.cos(yaw), np.sin(yaw)
    lx = np.array([-1.0, 1.0, 1.0, -1.0])[None, :] * hx[:, None]
    lz = np.array([-1.0, -1.0, 1.0, 1.0])[None, :] * hz[:, None]
    gx = cx[:, None] + lx * c[:, None] + lz * s[:, None]
    gz = cz[:, None] - lx * s[:, None] + lz * c[:, None]
    b = len(rows)
    lo = np.stack([gx, np.repeat(y0[:, None], 4, 1), gz], axis=-1)  # (B, 4, 3)
    hi = np.stack([gx, np.repeat(y1[:, None], 4, 1), gz], axis=-1)
    j = np.array([1, 2, 3, 0])
    sides = np.stack([lo, lo[:, j], hi[:, j], hi], axis=2)  # (B, 4 sides, 4, 3)
    faces = np.concatenate([hi[:, None, ::-1], sides], axis=1)  # (B, 5, 4, 3)
    nl = _SIDE_NORMALS_LOCAL
    nx = nl[None, :, 0] * c[:, None] + nl[None, :, 1] * s[:, None]
    nz = -nl[None, :, 0] * s[:, None] + nl[None, :, 1] * c[:, None]
    side_n = np.stack([nx, np.zeros_like(nx), nz], axis=-1)
    normals = np.concatenate([np.tile([0.0, 1.0, 0.0], (b, 1, 1)), side_n], axis=1)
    shade = 0.62 + 0.38 * np.clip(normals @ SUN, 0.0, 1.0)
    colors = rows[:, None, 7:10] * shade[..., None]
    group = rows[:, 11].astype(int)
    centre = np.stack([cx, 0.5 * (y0 + y1), cz], axis=1)[group]
    order = np.arange(b)[:, None] * 8.0 + np.arange(5)[None, :]
    wire = np.repeat(rows[:, 10] > 0, 5)
    first = batch.add(
        faces.reshape(-1, 4, 3),
        colors.reshape(-1, 3),
        LAYER_OBJECT,
        normals.reshape(-1, 3),
        np.repeat(centre, 5, axis=0),
        order.reshape(-1),
        wire,
    )
    for row, label in labels.items():
        for face in (1, 3):  # front and rear
            batch.labels[first + row * 5 + face] = label


def add_lamps(batch: QuadBatch, lamps: np.ndarray, boxes: np.ndarray) -> None:
    """Lamp quads drawn right after the box they sit on."""
    if not len(lamps) or not len(boxes):
        return
    x, y, z, nx, nz, hw, hh = (lamps[:, i] for i in range(7))
    tx, tz = -nz, nx
    pts = []
    for a, bb in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        pts.append(np.stack([x + a * hw * tx, y + bb * hh, z + a * hw * tz], axis=1))
    quads = np.stack(pts, axis=1)
    parent = lamps[:, 10].astype(int)
    group = boxes[parent, 11].astype(int)
    centre = np.stack([boxes[group, 0], 0.5 * (boxes[group, 3] + boxes[group, 4]), boxes[group, 1]], axis=1)
    normals = np.stack([nx, np.zeros_like(nx), nz], axis=1)
    batch.add(quads, lamps[:, 7:10], LAYER_OBJECT, normals, centre, np.full(len(lamps), 1e6))


@dataclass
class Fog:
    color: tuple[int, int, int]
    density_per_m: float

    def amount(self, depth: np.ndarray) -> np.ndarray:
        return 1.0 - np.exp(-self.density_per_m * np.maximum(depth, 0.0))


def draw(surface: Any, cam: Camera, batch: QuadBatch, fog: Fog | None = None) -> int:
    """Draw the batch onto the surface; returns how many polygons were drawn."""
    if batch.count == 0:
        return 0
    pg = _pg.pygame()
    w, h = surface.get_size()
    quads = np.concatenate(batch.quads)
    colors = np.concatenate(batch.colors)
    normals = np.concatenate(batch.normals)
    layers = np.concatenate(batch.layers)
    centres = np.concatenate(batch.centres)
    orders = np.concatenate(batch.orders)
    wire = np.concatenate(batch.wire)
    eye = np.array([cam.x, cam.y, cam.z])
    view = cam.to_view(quads)
    depth = view[..., 2]
    any_in = (depth > cam.near).any(axis=1) & (depth.min(axis=1) < cam.far)
    facing = np.einsum("ij,ij->i", normals, eye - quads.mean(axis=1)) > 0.0
    keep = any_in & (facing | ~normals.any(axis=1))
    all_in: np.ndarray = np.asarray((depth > cam.near).all(axis=1))
    screen = np.zeros(quads.shape[:2] + (2,))
    screen[all_in] = cam.project(view[all_in], w, h)
    on_screen = np.ones(len(quads), bool)
    sx, sy = screen[..., 0], screen[..., 1]
    on_screen[all_in] = ~((sx[all_in] < 0).all(1) | (sx[all_in] > w).all(1) | (sy[all_in] < 0).all(1) | (sy[all_in] > h).all(1))
    keep &= on_screen
    idx = np.flatnonzero(keep)
    if not len(idx):
        return 0
    dist = np.linalg.norm(centres[idx] - eye, axis=1)
    order = idx[np.lexsort((orders[idx], -dist, layers[idx]))]
    if fog is not None:
        poly_depth = np.maximum(depth[order].mean(axis=1), 0.0)
        amount = fog.amount(poly_depth)[:, None]
        colors = colors.copy()
        colors[order] = colors[order] * (1 - amount) + np.asarray(fog.color, float) * amount
    cols = np.clip(colors[order], 0, 255).astype(int).tolist()
    pts_all = screen[order].tolist()
    full = all_in[order].tolist()
    wires = wire[order].tolist()
    polygon = pg.draw.polygon
    labels = batch.labels
    for k, i in enumerate(order.tolist()):
        if full[k]:
            pts = pts_all[k]
        else:
            clipped = clip_near(view[i], cam.near)
            if len(clipped) < 3:
                continue
            pts = cam.project(clipped, w, h).tolist()
        if wires[k]:
            polygon(surface, cols[k], pts, 1)
            continue
        polygon(surface, cols[k], pts)
        if i in labels:
            _label(surface, labels[i], pts, cam.mirror)
    return len(order)


def _label(surface: Any, label: str, pts: list[list[float]], mirrored: bool) -> None:
    """Text on a sign board, fitted into the board's on-screen bounding box."""
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    bw, bh = max(xs) - min(xs), max(ys) - min(ys)
    if bw < 14 or bh < 8:
        return
    pg = _pg.pygame()
    img = _pg.font(max(8, int(bh * 0.6)), True).render(label, True, (250, 250, 250))
    scale = min(0.85 * bw / img.get_width(), 0.7 * bh / img.get_height(), 4.0)
    if scale <= 0 or math.isnan(scale):
        return
    img = pg.transform.smoothscale_by(img, scale) if scale != 1.0 else img
    if mirrored:
        img = pg.transform.flip(img, True, False)
    surface.blit(img, img.get_rect(center=(0.5 * (max(xs) + min(xs)), 0.5 * (max(ys) + min(ys)))))
