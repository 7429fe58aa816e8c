"""`DriverViewRenderer`: the 3D view from the driver's seat (or a chase or top camera).

Why: perception research and human sessions need what the driver sees, on machines with
no display and no GPU. Sky and ground are per-row gradients (fogged by the ground depth of
each row), the road and every object are quads sorted by the painter's algorithm
(`raster`), then rain and snow go on top. Camera modes follow OpenDS's `cameraMode`:
ego (driver's eye), chase (behind and above), static_back (further back), top (straight
down, car pointing up).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _pg
from . import palette as pal
from .camera import OPENDS_VFOV_DEG, Camera
from .raster import LAYER_GROUND, LAYER_MARKING, QuadBatch, add_boxes, add_lamps, draw, ground_quads, line_quads
from .road_layout import RoadLayout
from .scene import WorldScene
from .weather import Precipitation, fog_for, weather_of

CAMERA_MODES = ("ego", "chase", "static_back", "top")
# driver's eye relative to the car's reference point: behind it, left of centre, above the ground
EYE_BACK_M, EYE_LEFT_M, EYE_HEIGHT_M = 0.25, 0.35, 1.2
CHASE = {"chase": (7.0, 2.8, math.radians(-10.0)), "static_back": (12.0, 4.5, math.radians(-14.0))}
TOP_HEIGHT_M = 45.0
WIDE_ASPECT = 16.0 / 9.0
ROAD_RADIUS_M = 1000.0
OBJECT_RADIUS_M = 500.0


# ground pieces get shorter near the viewer so fog and near-plane clipping stay smooth
def _breaks(first_m: float = 1.5, growth: float = 1.16, limit_m: float = ROAD_RADIUS_M) -> np.ndarray:
    out = [first_m]
    while out[-1] * growth + 1.0 < limit_m:
        out.append(out[-1] * growth + 1.0)
    return np.asarray(out)


ROAD_BREAKS_M = _breaks()


def default_vfov_rad(width: int, height: int) -> float:
    """OpenDS's 30.5 degree vertical field of view on wide frames; narrower frames (an
    84x84 observation) keep the horizontal field of view of a 16:9 frame instead."""
    v = math.radians(OPENDS_VFOV_DEG)
    aspect = width / max(1, height)
    if aspect >= WIDE_ASPECT:
        return v
    h = 2.0 * math.atan(math.tan(0.5 * v) * WIDE_ASPECT)
    return 2.0 * math.atan(math.tan(0.5 * h) / aspect)


class DriverViewRenderer:
    """3D view of a World. `render(w, h)` -> uint8 (h, w, 3); `draw(surface, cam)` for compositions."""

    def __init__(
        self, world: Any, camera_mode: str = "ego", vfov_deg: float | None = None, show_triggers: bool = False, weather: bool = True
    ) -> None:
        if camera_mode not in CAMERA_MODES:
            raise ValueError(f"unknown camera mode {camera_mode!r}; choose from {', '.join(CAMERA_MODES)}")
        self.world = world
        self.camera_mode = camera_mode
        self.vfov_deg = vfov_deg
        self.weather = weather
        self.scene = WorldScene(world, show_triggers=show_triggers)
        self.road = RoadLayout(world)
        self.precipitation = Precipitation()
        self._backgrounds: dict[tuple[Any, ...], Any] = {}  # per viewport size and camera (screens, mirrors)
        self._surface: Any = None

    # ------------------------------------------------------------------ cameras
    def camera(
        self,
        width: int,
        height: int,
        mode: str | None = None,
        yaw_offset: float = 0.0,
        pitch: float = 0.0,
        hfov_rad: float | None = None,
        mirror: bool = False,
        eye_offset: tuple[float, float, float] | None = None,
        vfov_rad: float | None = None,
    ) -> Camera:
        """A camera on the ego car: `mode` one of CAMERA_MODES; offsets for extra screens and mirrors.

        `eye_offset` is (right, up, back) metres from the car's reference point at ground level.
        """
        s = self.world.ego.state
        mode = mode or self.camera_mode
        vfov = vfov_rad or (math.radians(self.vfov_deg) if self.vfov_deg else default_vfov_rad(width, height))
        fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
        rx, rz = math.cos(s.yaw), -math.sin(s.yaw)
        if mode == "ego" or eye_offset is not None:
            right, up, back = eye_offset if eye_offset is not None else (-EYE_LEFT_M, EYE_HEIGHT_M, EYE_BACK_M)
            x, y, z = s.x + right * rx - back * fx, s.y + up, s.z + right * rz - back * fz
            return Camera(x, y, z, s.yaw + yaw_offset, pitch, vfov, hfov_rad, 0.3, mirror=mirror)
        if mode == "top":
            return Camera(s.x, s.y + TOP_HEIGHT_M, s.z, s.yaw + yaw_offset, -0.5 * math.pi, vfov, hfov_rad, 1.0, mirror=mirror)
        back, up, tilt = CHASE[mode]
        return Camera(s.x - back * fx, s.y + up, s.z - back * fz, s.yaw + yaw_offset, tilt + pitch, vfov, hfov_rad, 0.5, mirror=mirror)

    # ------------------------------------------------------------------ drawing
    def render(self, width: int, height: int) -> np.ndarray:
        return _pg.to_array(self.render_surface(width, height))

    def render_surface(self, width: int, height: int) -> Any:
        """Draw a frame onto this renderer's own offscreen surface and return that surface."""
        if self._surface is None or self._surface.get_size() != (width, height):
            self._surface = _pg.new_surface(width, height)
        self.draw(self._surface, self.camera(width, height))
        return self._surface

    def draw(self, surface: Any, cam: Camera) -> None:
        """Draw the world as seen by `cam` onto the whole of `surface`."""
        w, h = surface.get_size()
        ground_y = self.world.ego.state.y
        weather = weather_of(self.world) if self.weather else {}
        fog = fog_for(weather)
        surface.blit(self._sky_and_ground(w, h, cam, cam.y - ground_y, fog), (0, 0))
        batch = QuadBatch()
        radius = min(cam.far, ROAD_RADIUS_M)
        road = self.road.pieces(cam.x, cam.z, radius, ROAD_BREAKS_M)
        batch.add(ground_quads(road.quads, ground_y + 0.01), road.quad_colors, LAYER_GROUND)
        batch.add(line_quads(road.lines, road.line_half_w, ground_y + 0.02), road.line_colors, LAYER_MARKING)
        s = self.world.ego.state
        outside = math.hypot(cam.x - s.x, cam.z - s.z) > 2.5 or cam.y - ground_y > 3.0  # not sitting in the car
        boxes, lamps = self.scene.collect(cam.x, cam.z, min(cam.far, OBJECT_RADIUS_M), include_ego=outside, buried_below_y=ground_y)
        rows = boxes.array()
        add_boxes(batch, rows, boxes.labels)
        add_lamps(batch, lamps.array(), rows)
        draw(surface, cam, batch, fog)
        if weather:
            self.precipitation.draw(surface, weather, self.world.t_s)

    def _sky_and_ground(self, w: int, h: int, cam: Camera, eye_height: float, fog: Any) -> Any:
        key = (w, h, round(cam.pitch, 4), round(eye_height, 3), cam.vfov_rad, cam.hfov_rad, None if fog is None else fog.density_per_m)
        cached = self._backgrounds.get(key)
        if cached is not None:
            return cached
        depth = cam.ground_row_depths(w, h, max(eye_height, 0.05))
        sky = np.isinf(depth)
        t_far = np.clip(np.where(sky, 1.0, depth / 400.0), 0.0, 1.0)[:, None]
        ground = np.asarray(pal.GRASS, float) * (1 - t_far) + np.asarray(pal.GRASS_FAR, float) * t_far
        fpx = cam.focal_px(w, h)
        a = (0.5 * h - (np.arange(h) + 0.5)) / fpx
        elev = np.clip((np.arctan(a) + cam.pitch) / 0.6, 0.0, 1.0)[:, None]
        sky_col = np.asarray(pal.SKY_HORIZON, float) * (1 - elev) + np.asarray(pal.SKY_ZENITH, float) * elev
        rows = np.where(sky[:, None], sky_col, ground)
        if fog is not None:
            amount = fog.amount(np.where(sky, 1e5, depth))[:, None]
            rows = rows * (1 - amount) + np.asarray(fog.color, float) * amount
        column = np.clip(rows, 0, 255).astype(np.uint8)
        pg = _pg.pygame()
        strip = pg.surfarray.make_surface(column[None, :, :])
        bg = pg.transform.scale(strip, (w, h))
        if len(self._backgrounds) >= 8:
            self._backgrounds.pop(next(iter(self._backgrounds)))
        self._backgrounds[key] = bg
        return bg
