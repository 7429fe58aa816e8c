"""The participant's window: the render package's composed view plus the session overlay.

Why: the drawing (3D driver view, mirrors, screens, top view, HUD) belongs to
`opends_gym.render` (`ViewComposer`, `HudOverlay`, `FrameWindow`); this module puts it in
a window each frame, applies the display keys of `ViewState` (camera, mirror, top view,
weather keys - the last only for the drawing, restored right after, so the World is
untouched), and draws what only the session knows: a hold (pause, instruction screen,
unplugged wheel), device messages (the CAN gateway's `display`) and connection problems.
"""

from __future__ import annotations

import os
from typing import Any

from .view_state import Overlay

HEADLESS_DRIVERS = ("offscreen", "dummy")
WINDOW_PER_SCREEN_ENV = "OPENDS_GYM_WINDOW_PER_SCREEN"  # 1: one window per OpenDS screen instead of one wide window
HOLD_COLOUR = (250, 220, 80)
STATUS_COLOUR = (255, 120, 90)


def init_headless_pygame() -> None:
    """pygame events (joystick hot-plug, axes) without a window: the dummy video driver if no display."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("SDL_JOYSTICK_ALLOW_BACKGROUND_EVENTS", "1")
    from ..render import _pg

    pg = _pg.pygame()
    pg.display.init()
    pg.joystick.init()


class DriveViewer:
    """A window showing the composed view and the session overlay."""

    def __init__(
        self, world: Any, settings: Any, width: int, height: int, title: str = "opends-gym drive", window_per_screen: bool | None = None
    ) -> None:
        os.environ.setdefault("SDL_JOYSTICK_ALLOW_BACKGROUND_EVENTS", "1")
        from ..render.compose import ViewComposer
        from ..render.screen_windows import ScreenWindows
        from ..render.window import FrameWindow

        self.world = world
        self.settings = settings
        if window_per_screen is None:
            window_per_screen = os.environ.get(WINDOW_PER_SCREEN_ENV, "").strip() in ("1", "true", "yes")
        screens = max(1, int(getattr(getattr(settings, "general", None), "number_of_screens", None) or 1))
        self.window: Any
        if window_per_screen and screens > 1:  # the same wide frame, one slice (width / screens) per window
            self.window = ScreenWindows(screens, width // screens, height, title=title)
        else:
            self.window = FrameWindow(width, height, title=title)
        from ..render import _pg

        driver = _pg.pygame().display.get_driver()
        if driver in HEADLESS_DRIVERS:  # SDL fell back to drawing into memory: nobody would see the drive
            self.window.close()
            raise RuntimeError(f"no display (SDL video driver '{driver}')")
        self.composer = ViewComposer(world, settings)
        self.base_mirror_mode = self.composer.mirror_mode
        self.base_top_view = self.composer.top_view

    @property
    def surface(self) -> Any:
        return self.window.screen

    def events(self) -> list[Any]:
        return self.window.pump()

    def _apply_view(self, overlay: Overlay) -> None:
        v = overlay.view
        c = self.composer
        c.view.camera_mode = v.camera_mode
        c.view.headlights = v.headlights
        mirror = self.base_mirror_mode if self.base_mirror_mode != "off" else "back_only"
        c.mirror_mode = mirror if v.mirror else "off"
        c.top_view = v.top_view or self.base_top_view

    def draw(self, overlay: Overlay) -> None:
        from ..render import _pg

        pg = _pg.pygame()
        self._apply_view(overlay)
        surface = self.window.screen
        trig = self.world.triggers
        weather = trig.weather
        trig.weather = overlay.view.weather(weather)
        try:
            self.composer.draw(surface)
        finally:
            trig.weather = weather
        hud = self.composer.hud
        sw, sh = surface.get_size()
        if overlay.instruction is not None and hud is not None:
            hud.draw_instructions(surface, overlay.instruction)
        elif overlay.hold and hud is not None:
            hud.draw_banner(surface, overlay.hold, HOLD_COLOUR)
        size = max(12, sh // 36)
        y = sh - size * (len(overlay.messages) + 1)
        for text in overlay.messages:
            _pg.text(surface, text, (sw // 2, y), size, (255, 255, 255), "midtop")
            y += size
        for i, text in enumerate(overlay.status):
            _pg.text(surface, text, (8, 8 + i * size), size, STATUS_COLOUR)
        if overlay.view.show_stats and overlay.snapshot is not None:
            s = overlay.snapshot
            _pg.text(surface, f"t {s.t_s:7.2f} s  fps {self.window.clock.get_fps():5.1f}", (8, sh - size - 4), size, (230, 230, 230))
        if hasattr(self.window, "flip"):
            self.window.flip()  # one window per screen
        else:
            pg.display.flip()
        self.window.clock.tick()  # measures the frame rate for the stats line; never waits

    def save_png(self, path: str) -> None:
        from ..render import _pg

        _pg.pygame().image.save(self.window.screen, path)

    def close(self) -> None:
        self.window.close()


def make_viewer(world: Any, settings: Any, width: int, height: int, title: str = "opends-gym drive") -> DriveViewer:
    return DriveViewer(world, settings, width, height, title)
