"""Headless renderers for OpenDS worlds: a top-down map, a 3D driver view, the HUD, and
the human viewer's composition and window.

Why: `render_mode="rgb_array"`, image observations and the human viewer all draw a
`sim.World` without a display: the 3D views and the map are Panda3D scene graphs drawn
offscreen (`engine`, `stage`), software-rendered unless a GL pipe is asked for; the HUD and
window are pygame. Neither is imported until a renderer is made.

`make_renderer(view, world, hud=False, **options)` -> an object with
`render(width, height)` returning uint8 (height, width, 3). Views: "topdown"
(`TopDownRenderer`), "driver_view" (the driver's eye, or any `camera_mode=`), "chase",
"static_back", "top" and "outside" (`DriverViewRenderer` camera modes), and "human" (the human
viewer's composition per the task's settings: screens, mirrors, top view and HUD).
`hud=True` draws the HUD (`hud.HudOverlay`) over any view. The 3D views and "human" take
`shadows="auto"|"on"|"off"` (`shadows.py`: sun shadows where the pipe has shaders).
"""

from __future__ import annotations

from typing import Any

RENDER_VIEWS = ("topdown", "driver_view", "chase", "static_back", "top", "outside", "human")


def make_renderer(view: str, world: Any, hud: bool = False, **options: Any) -> Any:
    """A renderer for `view` (one of RENDER_VIEWS) over `world`; options go to its constructor."""
    renderer: Any
    if view == "topdown":
        from .topdown import TopDownRenderer

        renderer = TopDownRenderer(world, **options)
    elif view in ("driver_view", "chase", "static_back", "top", "outside"):
        from .driver_view import DriverViewRenderer

        mode = options.pop("camera_mode", "ego") if view == "driver_view" else view
        renderer = DriverViewRenderer(world, camera_mode=mode, **options)
    elif view == "human":
        from .compose import ViewComposer

        return ViewComposer(world, options.pop("settings", None), hud=True, **options)
    else:
        raise ValueError(f"unknown render view {view!r}; choose from {', '.join(RENDER_VIEWS)}")
    if hud:
        from .hud import WithHud

        return WithHud(renderer, world)
    return renderer


def compose_view(world: Any, settings: Any, width: int, height: int) -> Any:
    """One frame of the human viewer (screens, mirrors, top view, HUD); see `compose.ViewComposer`."""
    from .compose import compose_view as _compose

    return _compose(world, settings, width, height)


__all__ = ["RENDER_VIEWS", "compose_view", "make_renderer"]
