"""Headless renderers for OpenDS worlds: a top-down map, a 3D driver view, the HUD, and
the human viewer's composition and window.

Why: `render_mode="rgb_array"`, image observations and the human viewer all draw a
`sim.World` without a display or a GL context (pygame Surfaces and numpy only). pygame is
imported on first use, never when this package is imported.

`make_renderer(view, world, **options)` -> an object with `render(width, height)`
returning uint8 (height, width, 3). Views: "topdown" (`TopDownRenderer`), "driver_view"
(the driver's eye), "chase", "static_back" and "top" (`DriverViewRenderer` camera modes).
"""

from __future__ import annotations

from typing import Any

RENDER_VIEWS = ("topdown", "driver_view", "chase", "static_back", "top")


def make_renderer(view: str, world: Any, **options: Any) -> Any:
    """A renderer for `view` (one of RENDER_VIEWS) over `world`; options go to its constructor."""
    if view == "topdown":
        from .topdown import TopDownRenderer

        return TopDownRenderer(world, **options)
    if view in ("driver_view", "chase", "static_back", "top"):
        from .driver_view import DriverViewRenderer

        return DriverViewRenderer(world, camera_mode="ego" if view == "driver_view" else view, **options)
    raise ValueError(f"unknown render view {view!r}; choose from {', '.join(RENDER_VIEWS)}")


def compose_view(world: Any, settings: Any, width: int, height: int) -> Any:
    """One frame of the human viewer (screens, mirrors, top view, HUD); see `compose.ViewComposer`."""
    from .compose import compose_view as _compose

    return _compose(world, settings, width, height)


__all__ = ["RENDER_VIEWS", "compose_view", "make_renderer"]
