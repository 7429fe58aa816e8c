"""`TopDownRenderer`: a bird's-eye map centred on the ego car, cheap enough for observations.

Why: image observations for RL need thousands of frames per minute; a map with the road,
signs, traffic and lights is the cheapest picture that still carries the task. Drawn with
pygame on an offscreen surface (no display). Heading-up (the car points up, placed low in
the frame to show more road ahead) or north-up (-Z up, the car centred). The scale in
px/m is fixed by `scale_px_per_m`, or fits `view_m` metres across the shorter side.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _pg
from . import palette as pal
from .road_layout import RoadLayout
from .scene import LAMPS_BY_STATE, WIRE, WorldScene

LIGHT_COLORS = {
    (True, False, False): pal.LAMP_RED,
    (False, True, False): pal.LAMP_YELLOW,
    (False, False, True): pal.LAMP_GREEN,
    (True, True, False): pal.LAMP_YELLOW,
    (True, True, True): pal.LAMP_YELLOW,
}


class TopDownRenderer:
    """Map of a World around its ego car. `render(w, h)` -> uint8 (h, w, 3)."""

    def __init__(
        self,
        world: Any,
        scale_px_per_m: float | None = None,
        view_m: float = 60.0,
        heading_up: bool = True,
        ego_at: float = 0.75,
        show_triggers: bool = False,
        show_ideal_tracks: bool = True,
    ) -> None:
        if scale_px_per_m is not None and not scale_px_per_m > 0:
            raise ValueError(f"scale_px_per_m must be positive, not {scale_px_per_m!r}")
        if not view_m > 0:
            raise ValueError(f"view_m must be positive, not {view_m!r}")
        self.world = world
        self.scale_px_per_m = scale_px_per_m
        self.view_m = float(view_m)
        self.heading_up = heading_up
        self.ego_at = float(ego_at) if heading_up else 0.5
        self.show_ideal_tracks = show_ideal_tracks
        self.scene = WorldScene(world, show_triggers=show_triggers)
        self.road = RoadLayout(world)
        self._surface: Any = None

    def render(self, width: int, height: int) -> np.ndarray:
        return _pg.to_array(self.render_surface(width, height))

    def render_surface(self, width: int, height: int) -> Any:
        """Draw a frame onto this renderer's own offscreen surface and return that surface."""
        if self._surface is None or self._surface.get_size() != (width, height):
            self._surface = _pg.new_surface(width, height)
        self.draw(self._surface)
        return self._surface

    def draw(
        self,
        surface: Any,
        centre: tuple[float, float] | None = None,
        scale_px_per_m: float | None = None,
        heading_up: bool | None = None,
        ego_at: float | None = None,
    ) -> None:
        """Draw the map onto the whole of `surface` (arguments override the renderer's settings)."""
        pg = _pg.pygame()
        w, h = surface.get_size()
        s = self.world.ego.state
        cx, cz = centre if centre is not None else (s.x, s.z)
        scale = scale_px_per_m or self.scale_px_per_m or min(w, h) / self.view_m
        up = self.heading_up if heading_up is None else heading_up
        yaw = s.yaw if up else 0.0
        c, sn = math.cos(yaw), math.sin(yaw)
        ox, oy = 0.5 * w, h * ((self.ego_at if up else 0.5) if ego_at is None else ego_at)
        radius = math.hypot(w, h) / scale

        def to_px(x: np.ndarray, z: np.ndarray) -> np.ndarray:
            dx, dz = x - cx, z - cz
            return np.stack([ox + scale * (dx * c - dz * sn), oy + scale * (dx * sn + dz * c)], axis=-1)

        surface.fill(pal.GRASS)
        polygon, line = pg.draw.polygon, pg.draw.line
        road = self.road.pieces(cx, cz, radius)
        if len(road.quads):
            for pts, col in zip(to_px(road.quads[..., 0], road.quads[..., 1]).tolist(), road.quad_colors.astype(int).tolist()):
                polygon(surface, col, pts)
        if len(road.lines):
            ends = to_px(road.lines[:, [0, 2]], road.lines[:, [1, 3]])  # (M, 2 ends, 2)
            ex, ey = ends[..., 0], ends[..., 1]
            seen = ~(((ex < 0).all(1)) | ((ex > w).all(1)) | ((ey < 0).all(1)) | ((ey > h).all(1)))
            widths = np.maximum(1, np.round(2 * road.line_half_w[seen] * scale)).astype(int).tolist()
            for (p0, p1), col, wd in zip(ends[seen].tolist(), road.line_colors[seen].astype(int).tolist(), widths):
                line(surface, col, p0, p1, wd)
        if self.show_ideal_tracks:
            tl = self.road.track_lines(cx, cz, radius)
            if len(tl):
                for p0, p1 in zip(to_px(tl[:, 0], tl[:, 1]).tolist(), to_px(tl[:, 2], tl[:, 3]).tolist()):
                    line(surface, pal.IDEAL_TRACK, p0, p1, 1)
        boxes, lamps = self.scene.collect(cx, cz, radius, include_ego=True)
        rows = boxes.array()
        if len(rows):
            bx, bz, byaw, hx, hz = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 5], rows[:, 6]
            bc, bs = np.cos(byaw)[:, None], np.sin(byaw)[:, None]
            lx = np.array([-1.0, 1.0, 1.0, -1.0])[None, :] * hx[:, None]
            lz = np.array([-1.0, -1.0, 1.0, 1.0])[None, :] * hz[:, None]
            corners = to_px(bx[:, None] + lx * bc + lz * bs, bz[:, None] - lx * bs + lz * bc).tolist()
            colors = rows[:, 7:10].astype(int).tolist()
            wires = (rows[:, 10] == WIRE).tolist()
            for i in np.argsort(rows[:, 4], kind="stable").tolist():  # low things first, overhead beams last
                polygon(surface, colors[i], corners[i], 1 if wires[i] else 0)
        lamp_rows = lamps.array()
        if len(lamp_rows):
            low = lamp_rows[:, 1] < 2.5 + self.world.ego.state.y  # car lamps; traffic-light lamps are drawn as one disc
            lr = lamp_rows[low]
            tx, tz = -lr[:, 4], lr[:, 3]
            p0 = to_px(lr[:, 0] - lr[:, 5] * tx, lr[:, 2] - lr[:, 5] * tz).tolist()
            p1 = to_px(lr[:, 0] + lr[:, 5] * tx, lr[:, 2] + lr[:, 5] * tz).tolist()
            wd = max(1, round(0.3 * scale))
            for a0, a1, col in zip(p0, p1, lr[:, 7:10].astype(int).tolist()):
                line(surface, col, a0, a1, wd)
        for x, z, state in self.scene.light_states:
            col = LIGHT_COLORS.get(LAMPS_BY_STATE.get(state, (False, False, False)), pal.LAMP_DARK)
            px = to_px(np.array(x), np.array(z)).tolist()
            pg.draw.circle(surface, col, px, max(2, round(0.6 * scale)))
