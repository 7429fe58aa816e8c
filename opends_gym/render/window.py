"""`FrameWindow`: a pygame-ce window that shows rendered frames and hands back its events.

Why: `render_mode="human"` and the human runner need a window, and the runner reads the
keyboard and joystick from the same window's event queue. pygame is imported and its
display opened only when a window is created; nothing global is set at import time.
`show()` paces to `fps` with a pygame clock (wall-clock pacing is a viewer concern; the
simulation itself never reads the clock).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from . import _pg


def pump_pygame(on_event: Callable[[Any], None] | None, close_types: tuple[str, ...]) -> tuple[list[Any], bool]:
    """pygame's pending events, each passed to `on_event`; and whether one of them (of the
    pygame event types named) asks to close the window."""
    pg = _pg.pygame()
    closing = {getattr(pg, name) for name in close_types}
    events = pg.event.get()
    for e in events:
        if on_event is not None:
            on_event(e)
    return events, any(e.type in closing for e in events)


class FrameWindow:
    """A window of `width` x `height` pixels. Frames of another size are scaled to fit."""

    def __init__(
        self, width: int, height: int, title: str = "opends_gym", on_event: Callable[[Any], None] | None = None, resizable: bool = False
    ) -> None:
        if width <= 0 or height <= 0:
            raise ValueError(f"window size must be positive, not {width}x{height}")
        pg = _pg.pygame()
        if not pg.display.get_init():
            pg.display.init()
        flags = pg.RESIZABLE if resizable else 0
        self.screen = pg.display.set_mode((int(width), int(height)), flags)
        pg.display.set_caption(title)
        self.clock = pg.time.Clock()
        self.on_event = on_event
        self.closed_by_user = False
        self._events: list[Any] = []
        self._open = True

    @property
    def is_open(self) -> bool:
        return self._open

    def show(self, frame: np.ndarray, fps: float | None = None) -> list[Any]:
        """Blit an (h, w, 3) uint8 frame, flip, pump events, wait to keep `fps`; returns the events."""
        if not self._open:
            raise RuntimeError("show() on a closed FrameWindow")
        pg = _pg.pygame()
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3:
            raise ValueError(f"frame must have shape (height, width, 3), not {frame.shape}")
        img = _pg.from_array(frame)
        size = self.screen.get_size()
        if img.get_size() != size:
            img = pg.transform.smoothscale(img, size)
        self.screen.blit(img, (0, 0))
        pg.display.flip()
        self.pump()
        if fps:
            self.clock.tick(fps)
        return list(self._events)

    def pump(self) -> list[Any]:
        """Read the window's pending events (also kept for `events()`); a close request is noted."""
        self._events, closed = pump_pygame(self.on_event, ("QUIT",))
        self.closed_by_user |= closed
        return list(self._events)

    def events(self) -> list[Any]:
        """The pygame events pumped by the last `show()` or `pump()`."""
        return list(self._events)

    def close(self) -> None:
        if self._open:
            pg = _pg.pygame()
            pg.display.quit()
            self._open = False

    def __enter__(self) -> FrameWindow:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
