"""`ScreenWindows`: one window per OpenDS screen, instead of one wide window across them.

Why: OpenDS draws `numberOfScreens` screens side by side into one wide frame, each camera
turned by `angleBetweenAdjacentCameras` (`ViewComposer.screen_views`). A lab whose monitors
are separate displays (or not one row of the X screen) wants one borderless window per
monitor. The composer still draws the one wide frame (so mirrors and the HUD sit where the
wide window would put them, across the screens as in OpenDS); each window shows its slice.
Same interface as `FrameWindow` where the drive viewer uses it (`screen`, `clock`, `pump`,
`events`, `flip`, `close`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from . import _pg
from .window import pump_pygame


class ScreenWindows:
    """`screens` windows of `width` x `height` each, window i at `positions[i]` (default: a row)."""

    def __init__(
        self,
        screens: int,
        width: int,
        height: int,
        title: str = "opends_gym",
        positions: Sequence[tuple[int, int]] | None = None,
        on_event: Callable[[Any], None] | None = None,
    ) -> None:
        if screens < 1 or width <= 0 or height <= 0:
            raise ValueError(f"screen windows need at least one screen of positive size, not {screens} x {width}x{height}")
        if positions is not None and len(positions) != screens:
            raise ValueError(f"{len(positions)} window positions given for {screens} screens")
        pg = _pg.pygame()
        if not pg.display.get_init():
            pg.display.init()
        self.width, self.height = int(width), int(height)
        where = positions or [(i * self.width, 0) for i in range(screens)]
        self.windows = [
            pg.Window(f"{title} ({i + 1}/{screens})", (self.width, self.height), position=tuple(where[i]), borderless=screens > 1)
            for i in range(screens)
        ]
        self.screen = _pg.new_surface(screens * self.width, self.height)  # the wide frame the composer draws
        self.clock = pg.time.Clock()
        self.on_event = on_event
        self.closed_by_user = False
        self._events: list[Any] = []
        self._open = True

    @property
    def is_open(self) -> bool:
        return self._open

    def flip(self) -> None:
        """Show each screen's slice of the wide frame in its window."""
        pg = _pg.pygame()
        for i, win in enumerate(self.windows):
            win.get_surface().blit(self.screen, (0, 0), pg.Rect(i * self.width, 0, self.width, self.height))
            win.flip()

    def pump(self) -> list[Any]:
        """Events of all the windows (a close request on any of them is noted)."""
        self._events, closed = pump_pygame(self.on_event, ("QUIT", "WINDOWCLOSE"))
        self.closed_by_user |= closed
        return list(self._events)

    def events(self) -> list[Any]:
        return list(self._events)

    def close(self) -> None:
        if self._open:
            for win in self.windows:
                win.destroy()
            _pg.pygame().display.quit()
            self._open = False
