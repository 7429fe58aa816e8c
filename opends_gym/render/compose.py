"""`ViewComposer`: the human viewer's frame - screens, mirrors, top view and HUD - per settings.xml.

Why: a lab session shows what OpenDS shows, laid out by the task's settings (OpenDS
`CameraFactory` defaults where a value is missing). Screens and mirrors are display
regions of one Panda3D frame (one render per frame, as OpenDS's viewports):

* `numberOfScreens` N side by side; each screen's camera turns by `angleBetweenAdjacentCameras`
  (default 40 degrees, which is also each screen's horizontal field of view); screen i
  (1-based) looks ((N+1)//2 - i) angles to the left. One screen: 30.5 degrees vertical.
* `cameraMode` ego | chase | static_back for the main view.
* `mirrorMode` off (default) | back_only | side_only | all, only in the ego view: the rear
  mirror (viewport 0.3-0.7 x 0.78-0.98, 30 degrees) and side mirrors (left 0.02-0.2, right
  0.8-0.98 x 0.3-0.6, 45 degrees, turned 45 degrees out and 10 down), images flipped.
  Viewport fractions count from the bottom-left, as in jME.
* `shadows=` auto | on | off (default: `OPENDS_GYM_SHADOWS`, else auto): sun shadows on the
  screens and mirrors where the graphics pipe has shaders (`shadows.py`).
* `topView`: a map inset (viewport 0.05-0.45 x 0.58-0.98), as seen from `verticalDistance`
  (200 m) with a 30 degree lens, the car `carOffset` (40 m) below the centre, pointing up
  unless `carPointingUp` is false.
"""

from __future__ import annotations

import math
import weakref
from typing import Any

import numpy as np

from . import _pg
from .camera import Camera
from .driver_view import DriverViewRenderer, Viewport, pixel_rect
from .hud import HudOverlay
from .topdown import TopDownRenderer

MIRROR_MODES = ("off", "back_only", "side_only", "all")
# (left, right, bottom, top, horizontal angle deg, vertical angle deg, vertical fov deg, eye (right, up, back) m)
MIRRORS = {
    "back": (0.3, 0.7, 0.78, 0.98, 0.0, 0.0, 30.0, (0.0, 1.25, -0.45)),
    "left": (0.02, 0.2, 0.3, 0.6, -45.0, 10.0, 45.0, (-0.95, 1.0, -0.9)),
    "right": (0.8, 0.98, 0.3, 0.6, 45.0, 10.0, 45.0, (0.95, 1.0, -0.9)),
}
TOP_VIEW = (0.05, 0.45, 0.58, 0.98, 200.0, 40.0)
TOP_VIEW_FOV_DEG = 30.0


def _viewport(width: int, height: int, left: float, right: float, bottom: float, top: float) -> tuple[int, int, int, int]:
    """Pixel rect (x, y, w, h) of a jME viewport (fractions from the bottom-left)."""
    x0, x1 = int(round(left * width)), int(round(right * width))
    y0, y1 = int(round((1.0 - top) * height)), int(round((1.0 - bottom) * height))
    return x0, y0, max(1, x1 - x0), max(1, y1 - y0)


def _or(value: Any, default: Any) -> Any:
    return default if value is None else value


class ViewComposer:
    """One frame of the human viewer. `render(w, h)` -> uint8 (h, w, 3); `draw(surface)`."""

    def __init__(
        self,
        world: Any,
        settings: Any = None,
        hud: bool = True,
        mirror_mode: str | None = None,
        top_view: bool | None = None,
        camera_mode: str | None = None,
        shadows: str | None = None,
    ) -> None:
        settings = settings if settings is not None else world.task.settings
        self.general = getattr(settings, "general", settings)
        g = self.general
        self.world = world
        self.screens = max(1, int(_or(g.number_of_screens, 1)))
        self.angle_rad = _or(g.angle_between_adjacent_cameras_rad, math.radians(40.0))
        if not 0.0 <= self.angle_rad <= 0.5 * math.pi:
            self.angle_rad = math.radians(40.0)  # OpenDS: must be within 0..90 degrees, else 40
        self.mirror_mode = _or(mirror_mode, _or(g.mirror_mode, "off"))
        if self.mirror_mode not in MIRROR_MODES:
            raise ValueError(f"unknown mirror mode {self.mirror_mode!r}; choose from {', '.join(MIRROR_MODES)}")
        self.top_view = g.top_view is not None if top_view is None else top_view
        mode = _or(camera_mode, _or(g.camera_mode, "ego"))
        self.view = DriverViewRenderer(world, camera_mode=mode, shadows=shadows)  # (None: OPENDS_GYM_SHADOWS, else auto)
        self.map = TopDownRenderer(world)
        self.hud = HudOverlay(world, number_of_screens=self.screens) if hud else None
        self._surface: Any = None

    def render(self, width: int, height: int) -> np.ndarray:
        return _pg.to_array(self.render_surface(width, height))

    def render_surface(self, width: int, height: int) -> Any:
        """Draw a frame onto this renderer's own offscreen surface and return that surface."""
        if self._surface is None or self._surface.get_size() != (width, height):
            self._surface = _pg.new_surface(width, height)
        self.draw(self._surface)
        return self._surface

    def draw(self, surface: Any) -> None:
        """Screens and mirrors in one Panda3D frame (display regions), then borders, top view and HUD."""
        w, h = surface.get_size()
        screens = self.screen_views(w, h)
        mirrors = [(name, *self.mirror_view(w, h, name)) for name in self.mirrors()] if self.view.camera_mode == "ego" else []
        self.view.blit_views(surface, [*screens, *((vp, cam) for _, vp, cam in mirrors)])
        self.view.precipitate_on(surface, [vp for vp, _ in screens])
        pg = _pg.pygame()
        for _, vp, _cam in mirrors:
            x, y, rw, rh = pixel_rect(w, h, vp)
            pg.draw.rect(surface, (25, 25, 25), pg.Rect(x, y, rw, rh).inflate(max(4, rw // 20), max(4, rh // 10)), max(2, rw // 40))
        if self.top_view:
            self.draw_top_view(surface)
        if self.hud is not None:
            self.hud.draw(surface)

    def mirrors(self) -> tuple[str, ...]:
        return {"off": (), "back_only": ("back",), "side_only": ("left", "right"), "all": ("back", "left", "right")}[self.mirror_mode]

    def screen_views(self, w: int, h: int) -> list[tuple[Viewport, Camera]]:
        """OpenDS's screens side by side, each turned by the angle between adjacent cameras."""
        n = self.screens
        if n == 1:
            return [((0.0, 1.0, 0.0, 1.0), self.view.camera(w, h))]
        out = []
        for i in range(1, n + 1):
            x0, x1 = (i - 1) * w // n, i * w // n
            yaw = ((n + 1) // 2 - i) * self.angle_rad
            out.append((((i - 1) / n, i / n, 0.0, 1.0), self.view.camera(x1 - x0, h, yaw_offset=yaw, hfov_rad=self.angle_rad)))
        return out

    def mirror_view(self, w: int, h: int, name: str) -> tuple[Viewport, Camera]:
        """A mirror's viewport (from the settings, else OpenDS's defaults) and its flipped camera."""
        left, right, bottom, top, h_deg, v_deg, fov_deg, eye = MIRRORS[name]
        vp = getattr(self.general, {"back": "rearview_mirror", "left": "left_mirror", "right": "right_mirror"}[name])
        if vp is not None:
            left, right, bottom, top = _or(vp.left, left), _or(vp.right, right), _or(vp.bottom, bottom), _or(vp.top, top)
            h_deg = math.degrees(vp.horizontal_angle_rad) if vp.horizontal_angle_rad is not None else h_deg
            v_deg = math.degrees(vp.vertical_angle_rad) if vp.vertical_angle_rad is not None else v_deg
        left, right = min(max(left, 0.0), 1.0), min(max(right, 0.0), 1.0)
        bottom, top = min(max(bottom, 0.0), 1.0), min(max(top, 0.0), 1.0)
        _, _, rw, rh = pixel_rect(w, h, (left, right, bottom, top))
        cam = self.view.camera(
            rw,
            rh,
            yaw_offset=math.pi + math.radians(h_deg),
            pitch=-math.radians(v_deg),
            mirror=True,
            eye_offset=eye,
            vfov_rad=math.radians(fov_deg),
        )
        return (left, right, bottom, top), cam

    def draw_top_view(self, surface: Any) -> None:
        pg = _pg.pygame()
        w, h = surface.get_size()
        left, right, bottom, top, dist, offset = TOP_VIEW
        tv = self.general.top_view
        up = True
        if tv is not None:
            left, right, bottom, top = _or(tv.left, left), _or(tv.right, right), _or(tv.bottom, bottom), _or(tv.top, top)
            dist, offset = _or(tv.vertical_distance_m, dist), _or(tv.car_offset_m, offset)
            up = _or(tv.car_pointing_up, True)
        rect = pg.Rect(_viewport(w, h, left, right, bottom, top)).clip(surface.get_rect())
        pg.draw.rect(surface, (25, 25, 25), rect.inflate(6, 6))
        sub = surface.subsurface(rect)
        seen_m = 2.0 * max(dist, 1.0) * math.tan(math.radians(0.5 * TOP_VIEW_FOV_DEG))
        self.map.draw(sub, scale_px_per_m=rect.height / seen_m, heading_up=up, ego_at=min(0.95, 0.5 + offset / seen_m))


_COMPOSERS: weakref.WeakKeyDictionary[Any, tuple[Any, ViewComposer]] = weakref.WeakKeyDictionary()


def compose_view(world: Any, settings: Any, width: int, height: int) -> np.ndarray:
    """The human viewer's frame for `world` (a composer is kept per world and settings object)."""
    entry = _COMPOSERS.get(world)
    if entry is None or entry[0] is not settings:
        entry = (settings, ViewComposer(world, settings))
        _COMPOSERS[world] = entry
    return entry[1].render(width, height)
