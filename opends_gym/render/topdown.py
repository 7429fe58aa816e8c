"""`TopDownRenderer`: a bird's-eye map centred on the ego car, cheap enough for observations.

Why: image observations for RL need thousands of frames per minute; a map with the road,
signs, traffic and lights is the cheapest picture that still carries the task. It is the
World's Panda3D scene graph (`stage.Stage`, the same one the driver view draws) seen by an
orthographic camera from above, plus map symbols only the map shows: lane lines at least a
pixel wide, ideal tracks, lamps seen from above and a disc per traffic light in its phase.
Heading-up (the car points up, placed low in the frame to show more road ahead) or
north-up (-Z up, the car centred). The scale in px/m is fixed by `scale_px_per_m`, or fits
`view_m` metres across the shorter side.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _pg
from . import palette as pal
from .engine import Offscreen, panda
from .stage import MAP_BIT, Stage

CAMERA_HEIGHT_M = 400.0  # above the ego; the orthographic lens sees everything below it


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
        self.stage = Stage(world, show_triggers=show_triggers)
        self.scene = self.stage.scene
        self.road = self.stage.road
        self._target: Offscreen | None = None
        self._cam: Any = None
        self._lens_key: tuple[Any, ...] = ()
        self._surface: Any = None

    def render(self, width: int, height: int) -> np.ndarray:
        return self._draw(width, height).rgb()

    def render_surface(self, width: int, height: int) -> Any:
        """A frame on this renderer's own offscreen pygame surface (for overlays such as the HUD)."""
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
        target = self._draw(w, h, centre, scale_px_per_m, heading_up, ego_at)
        fmt = {4: "BGRA", 3: "BGR"}[target.components()]
        img = pg.image.frombuffer(target.bgra_bytes(), (w, h), fmt)
        surface.blit(pg.transform.flip(img, False, True), (0, 0))

    def _draw(
        self,
        w: int,
        h: int,
        centre: tuple[float, float] | None = None,
        scale_px_per_m: float | None = None,
        heading_up: bool | None = None,
        ego_at: float | None = None,
    ) -> Offscreen:
        p3d = panda()
        if self._target is None or (self._target.width, self._target.height) != (w, h):
            if self._target is not None:
                self._target.close()
            g = pal.GRASS  # (a little over each level: see stage._rgba)
            self._target = Offscreen(w, h, clear=((g[0] + 0.1) / 255.0, (g[1] + 0.1) / 255.0, (g[2] + 0.1) / 255.0))
            if self._cam is None:
                self._cam = self.stage.root.attachNewNode(p3d.Camera("map", p3d.OrthographicLens()))
                self._cam.node().setCameraMask(p3d.BitMask32.bit(MAP_BIT))
            self._target.region(0.0, 1.0, 0.0, 1.0, camera=self._cam)
            self._lens_key = ()
        s = self.world.ego.state
        scale = scale_px_per_m or self.scale_px_per_m or min(w, h) / self.view_m
        up = self.heading_up if heading_up is None else heading_up
        at = (self.ego_at if up else 0.5) if ego_at is None else ego_at
        yaw = s.yaw if up else 0.0
        lens_key = (w, h, scale)
        if lens_key != self._lens_key:
            lens = self._cam.node().getLens()
            lens.setFilmSize(w / scale, h / scale)
            lens.setNearFar(1.0, 2.0 * CAMERA_HEIGHT_M)
            self._lens_key = lens_key
        self.stage.map_symbols(scale, self.show_ideal_tracks)
        cx, cz = centre if centre is not None else (s.x, s.z)
        ahead = (at - 0.5) * h / scale  # the frame's centre lies this far ahead of the car
        fx, fz = -math.sin(yaw), -math.cos(yaw)
        x, z = cx + ahead * fx, cz + ahead * fz
        self.stage.sync(x, s.y + CAMERA_HEIGHT_M, z, include_ego=True)
        self._cam.setPosHpr(x, -z, s.y + CAMERA_HEIGHT_M, math.degrees(yaw), -90.0, 0.0)
        self._target.render()
        return self._target
