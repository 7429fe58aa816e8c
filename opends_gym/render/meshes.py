"""Procedural low-poly meshes for the Panda3D views: boxes, ribbons, lamps, sky, signs.

Why: OpenDS's `.j3o` assets are not ours to ship, so every model is built here from a few
coloured boxes (`styles.Part`), and road surfaces from the lane geometry the simulation
already has. Geometry is written straight from numpy arrays into Panda3D vertex buffers
(one copy, no per-vertex Python). All coordinates passed in are OpenDS world/local
coordinates (Y up, -Z forward); they are turned into Panda3D's (x, -z, y) here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .engine import panda
from .palette import RGB
from .styles import Part

_FORMATS: dict[tuple[bool, bool], Any] = {}


def _format(normals: bool, uv: bool) -> Any:
    key = (normals, uv)
    fmt = _FORMATS.get(key)
    if fmt is None:
        p3d = panda()
        arr = p3d.GeomVertexArrayFormat()
        arr.addColumn(p3d.InternalName.getVertex(), 3, p3d.Geom.NTFloat32, p3d.Geom.CPoint)
        if normals:
            arr.addColumn(p3d.InternalName.getNormal(), 3, p3d.Geom.NTFloat32, p3d.Geom.CNormal)
        arr.addColumn(p3d.InternalName.getColor(), 4, p3d.Geom.NTFloat32, p3d.Geom.CColor)
        if uv:
            arr.addColumn(p3d.InternalName.getTexcoord(), 2, p3d.Geom.NTFloat32, p3d.Geom.CTexcoord)
        fmt = _FORMATS[key] = p3d.GeomVertexFormat.registerFormat(p3d.GeomVertexFormat(arr))
    return fmt


def vertex_format(normals: bool, uv: bool) -> Any:
    """The registered vertex format with positions, colours and optional normals and UVs."""
    return _format(normals, uv)


def to_panda_xyz(pts: np.ndarray) -> np.ndarray:
    """World (x, y, z) rows as Panda3D (x, -z, y)."""
    pts = np.asarray(pts, dtype=np.float32)
    return np.stack([pts[..., 0], -pts[..., 2], pts[..., 1]], axis=-1)


def geom_node(
    name: str,
    verts: np.ndarray,
    colors: np.ndarray,
    tris: np.ndarray,
    normals: np.ndarray | None = None,
    uv: np.ndarray | None = None,
) -> Any:
    """A GeomNode from Panda-space vertices (N, 3), RGB 0..255 or RGBA 0..1 colours (N, 3|4), triangles (M, 3)."""
    p3d = panda()
    n = len(verts)
    colors = np.asarray(colors, dtype=np.float32)
    if colors.shape[-1] == 3:
        colors = np.concatenate([colors / 255.0, np.ones((n, 1), np.float32)], axis=1)
    cols = [np.asarray(verts, np.float32)]
    if normals is not None:
        cols.append(np.asarray(normals, np.float32))
    cols.append(colors.astype(np.float32))
    if uv is not None:
        cols.append(np.asarray(uv, np.float32))
    data = np.ascontiguousarray(np.concatenate(cols, axis=1), dtype=np.float32)
    vdata = p3d.GeomVertexData(name, _format(normals is not None, uv is not None), p3d.Geom.UHStatic)
    vdata.uncleanSetNumRows(n)
    memoryview(vdata.modifyArray(0)).cast("B")[:] = data.tobytes()
    prim = p3d.GeomTriangles(p3d.Geom.UHStatic)
    prim.setIndexType(p3d.Geom.NTUint32)
    idx = np.ascontiguousarray(np.asarray(tris, np.uint32).reshape(-1))
    handle = prim.modifyVertices()
    handle.uncleanSetNumRows(len(idx))
    memoryview(handle).cast("B")[:] = idx.tobytes()
    geom = p3d.Geom(vdata)
    geom.addPrimitive(prim)
    node = p3d.GeomNode(name)
    node.addGeom(geom)
    return node


def _quads_to_tris(n_quads: int) -> np.ndarray:
    base = np.arange(n_quads, dtype=np.uint32)[:, None] * 4
    return (base + np.array([[0, 1, 2, 0, 2, 3]], np.uint32)).reshape(-1, 3)


# box faces (local x right, y up, z back): top, front (-z), right (+x), back (+z), left (-x), bottom
_FACES = (
    ((-1, 1, 1), (1, 1, 1), (1, 1, -1), (-1, 1, -1), (0, 1, 0)),
    ((-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (0, 0, -1)),
    ((1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1), (1, 0, 0)),
    ((1, -1, 1), (-1, -1, 1), (-1, 1, 1), (1, 1, 1), (0, 0, 1)),
    ((-1, -1, 1), (-1, -1, -1), (-1, 1, -1), (-1, 1, 1), (-1, 0, 0)),
    ((-1, -1, -1), (-1, -1, 1), (1, -1, 1), (1, -1, -1), (0, -1, 0)),
)
_CORNERS = np.asarray([[c for c in f[:4]] for f in _FACES], dtype=np.float32)  # (6, 4, 3)
_NORMALS = np.asarray([f[4] for f in _FACES], dtype=np.float32)  # (6, 3)


SUN_LOCAL = np.array([0.45, 0.8, 0.38]) / np.linalg.norm([0.45, 0.8, 0.38])  # towards the sun, in the object's frame
AMBIENT, DIFFUSE = 0.62, 0.38


def boxes_node(name: str, parts: tuple[Part, ...] | list[Part], bottom: bool = False, shade: bool = True) -> Any:
    """Upright boxes in an object's local frame (x right, z back, y up from its base), shaded by a
    sun baked into the vertex colours (flat, deterministic, and no lighting cost per frame)."""
    faces = 6 if bottom else 5
    verts, norms, cols = [], [], []
    for p in parts:
        centre = np.array([p.dx, 0.5 * (p.y0 + p.y1), p.dz], np.float32)
        half = np.array([p.hx, 0.5 * (p.y1 - p.y0), p.hz], np.float32)
        verts.append((centre + _CORNERS[:faces] * half).reshape(-1, 3))
        norms.append(np.repeat(_NORMALS[:faces], 4, axis=0))
        light = AMBIENT + DIFFUSE * np.clip(_NORMALS[:faces] @ SUN_LOCAL, 0.0, 1.0) if shade else np.ones(faces)
        cols.append(np.repeat(np.asarray(p.color, np.float32)[None, :] * light[:, None], 4, axis=0))
    if not verts:
        return panda().GeomNode(name)
    v = np.concatenate(verts)
    return geom_node(name, to_panda_xyz(v), np.concatenate(cols), _quads_to_tris(len(v) // 4), to_panda_xyz(np.concatenate(norms)))


def lamps_node(name: str, lamps: Sequence[tuple[float, ...]]) -> Any:
    """Flat lamp quads (x, y, z, nx, nz, half_w, half_h) in local coordinates, white (coloured by setColor)."""
    verts = []
    for x, y, z, nx, nz, hw, hh in lamps:
        tx, tz = -nz, nx
        verts.extend([(x + a * hw * tx, y + b * hh, z + a * hw * tz) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    v = np.asarray(verts, np.float32).reshape(-1, 3)
    return geom_node(name, to_panda_xyz(v), np.full((len(v), 3), 255.0, np.float32), _quads_to_tris(len(v) // 4))


def strip_node(name: str, left: np.ndarray, right: np.ndarray, color: RGB, y: float = 0.0) -> Any:
    """A ground ribbon between two (N, 2) x/z polylines, flat at height y."""
    n = len(left)
    xz = np.empty((2 * n, 2), np.float32)
    xz[0::2], xz[1::2] = left, right
    v = np.stack([xz[:, 0], -xz[:, 1], np.full(2 * n, y, np.float32)], axis=1)
    k = np.arange(n - 1, dtype=np.uint32)[:, None] * 2
    tris = np.concatenate([k + np.array([0, 1, 3], np.uint32), k + np.array([0, 3, 2], np.uint32)])
    return geom_node(name, v, np.tile(np.asarray(color, np.float32), (2 * n, 1)), tris)


def flat_quads_node(name: str, quads_xz: np.ndarray, colors: np.ndarray, y: float = 0.0) -> Any:
    """Flat ground quads (N, 4, 2) x/z with RGB colours (N, 3)."""
    q = np.asarray(quads_xz, np.float32).reshape(-1, 2)
    v = np.stack([q[:, 0], -q[:, 1], np.full(len(q), y, np.float32)], axis=1)
    return geom_node(name, v, np.repeat(np.asarray(colors, np.float32), 4, axis=0), _quads_to_tris(len(q) // 4))


def line_quads_xz(lines: np.ndarray, half_w: float) -> np.ndarray:
    """Painted lines (x0, z0, x1, z1) as flat (N, 4, 2) quads of their width."""
    p0, p1 = lines[:, :2], lines[:, 2:]
    d = p1 - p0
    n = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    off = n * half_w
    return np.stack([p0 + off, p1 + off, p1 - off, p0 - off], axis=1)


def disc_node(name: str, rings: list[tuple[float, RGB]], segments: int = 48) -> Any:
    """A flat disc at y = 0 around the origin: colours interpolate between (radius, colour) rings."""
    a = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    verts = [np.zeros((1, 3), np.float32)]
    cols = [np.asarray([rings[0][1]], np.float32)]
    for r, c in rings:
        verts.append(np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)], axis=1).astype(np.float32))
        cols.append(np.tile(np.asarray(c, np.float32), (segments, 1)))
    tris = [np.stack([np.zeros(segments), 1 + np.arange(segments), 1 + (np.arange(segments) + 1) % segments], axis=1)]
    for k in range(len(rings) - 1):
        i0 = 1 + k * segments + np.arange(segments)
        j0 = 1 + k * segments + (np.arange(segments) + 1) % segments
        i1, j1 = i0 + segments, j0 + segments
        tris += [np.stack([i0, i1, j1], axis=1), np.stack([i0, j1, j0], axis=1)]
    return geom_node(name, np.concatenate(verts), np.concatenate(cols), np.concatenate(tris).astype(np.uint32))


def textured_board_node(name: str, hx: float, y0: float, y1: float, hz: float, texture: Any) -> Any:
    """A sign board's front and back faces (the label texture), slightly in front of its box."""
    p3d = panda()
    z = hz + 0.01
    front = [(-hx, y0, -z), (hx, y0, -z), (hx, y1, -z), (-hx, y1, -z)]
    back = [(hx, y0, z), (-hx, y0, z), (-hx, y1, z), (hx, y1, z)]
    v = to_panda_xyz(np.asarray(front + back, np.float32))
    uv = np.tile(np.array([[1, 0], [0, 0], [0, 1], [1, 1]], np.float32), (2, 1))  # read the right way round from either side
    node = geom_node(name, v, np.full((8, 3), 255.0, np.float32), _quads_to_tris(2), uv=uv)
    np_ = p3d.NodePath(node)
    np_.setTexture(texture, 1)
    return np_


BACKGROUND_TOL = 1.0  # colour levels: the card's rows are as few as keep its gradients this close to exact


def background_colors(rows: np.ndarray, height: int, focal_px: float, pitch: float, eye_height_m: float) -> np.ndarray:
    """The sky or grass colour (float RGB) at screen rows (from the top, pixels) for a camera at
    `pitch` looking over flat ground `eye_height_m` below: the sky blends from the horizon colour
    to the zenith by elevation, the grass from near to far by the ground's distance (400 m)."""
    from . import palette as pal

    a = (0.5 * height - rows) / focal_px
    dy = math.sin(pitch) + a * math.cos(pitch)  # world-up part of each row's ray
    with np.errstate(divide="ignore"):
        depth = np.where(dy < -1e-9, eye_height_m / -dy * np.sqrt(1.0 + a * a), np.inf)
    sky = np.isinf(depth)
    t_far = np.clip(np.where(sky, 1.0, depth / 400.0), 0.0, 1.0)[:, None]
    ground = np.asarray(pal.GRASS, float) * (1 - t_far) + np.asarray(pal.GRASS_FAR, float) * t_far
    elev = np.clip((np.arctan(a) + pitch) / 0.6, 0.0, 1.0)[:, None]
    sky_col = np.asarray(pal.SKY_HORIZON, float) * (1 - elev) + np.asarray(pal.SKY_ZENITH, float) * elev
    return np.where(sky[:, None], sky_col, ground)


def _knots(y: np.ndarray, col: np.ndarray, tol: float) -> list[int]:
    """Indices into the fine samples `y` whose piecewise-linear interpolation of `col` stays
    within `tol` of every sample (greedy: each piece as long as a binary search finds)."""

    def fits(i: int, j: int) -> bool:
        t = ((y[i : j + 1] - y[i]) / (y[j] - y[i]))[:, None]
        return bool(np.abs(col[i] + t * (col[j] - col[i]) - col[i : j + 1]).max() <= tol)

    out, i, n = [0], 0, len(y)
    while i < n - 1:
        lo, hi = i + 1, n - 1
        if not fits(i, hi):
            while hi - lo > 1:  # fits(i, lo) holds, fits(i, hi) does not
                mid = (lo + hi) // 2
                lo, hi = (mid, hi) if fits(i, mid) else (lo, mid)
            hi = lo
        out.append(hi)
        i = hi
    return out


def background_rows(height: int, focal_px: float, pitch: float, eye_height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Screen rows (from the top, pixels) and their colour (`background_colors`) for a card that
    Gouraud-shades between them: a sharp edge at the horizon, and on either side only as many
    rows as keep the linear blend within BACKGROUND_TOL levels of the exact colour at every half
    pixel (each row is two triangles, and on the software pipe a triangle costs as much as a
    few hundred pixels: 84x84 needs about 10 rows, not one every 3 pixels)."""
    horizon = 0.5 * height + focal_px * math.tan(pitch) if abs(pitch) < 1.5 else (-1e9 if pitch < 0 else 1e9)
    edges = [0.0, float(height)]
    if 0.0 < horizon < height:
        edges = [0.0, horizon - 1e-3, horizon + 1e-3, float(height)]
    rows, cols = [], []
    for a, b in zip(edges[0::2], edges[1::2]):
        y = np.unique(np.concatenate([np.arange(a, b, 0.5), [b]]))
        col = background_colors(y, height, focal_px, pitch, eye_height_m)
        k = _knots(y, col, BACKGROUND_TOL) if len(y) > 1 else [0]
        rows.append(y[k])
        cols.append(col[k])
    return np.concatenate(rows), np.concatenate(cols)


def background_node(name: str, width: int, height: int, focal_px: float, pitch: float, eye_height_m: float, dist: float) -> Any:
    """A card filling a camera's view at `dist` (in the camera's own frame) painted with `background_rows`."""
    rows, cols = background_rows(height, focal_px, pitch, eye_height_m)
    n = len(rows)
    half_w = (0.5 * width + 2.0) / focal_px * dist
    z = (0.5 * height - rows) / focal_px * dist
    v = np.zeros((2 * n, 3), np.float32)
    v[0::2, 0], v[1::2, 0] = -half_w, half_w
    v[:, 1] = dist
    v[0::2, 2] = v[1::2, 2] = z
    k = np.arange(n - 1, dtype=np.uint32)[:, None] * 2
    tris = np.concatenate([k + np.array([0, 1, 3], np.uint32), k + np.array([0, 3, 2], np.uint32)])
    return geom_node(name, v, np.repeat(cols.astype(np.float32), 2, axis=0), tris)
