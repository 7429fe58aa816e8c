"""Screenshots of the participant's window (`opends-gym drive`'s `DriveViewer`) for four tasks.

Why: the docs show what a participant sees: the LCT (its lane signs up), the three-vehicle
platoon (TVPT), MotorwayTask and an OpenDRIVE task (init_drive). Each is drawn in a real
window (needs an X display: run under Xvfb), saved to docs/images/screens/. `shoot()` also
returns probes: world points (road, lane marking, sign, car) projected with the window
camera's lens, and the colours expected there; tests/test_screenshots.py samples them.

    xvfb-run -s "-screen 0 1920x1080x24" python docs/gen_screenshots.py [--size 1280x720]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "screens"
CORPUS = ROOT / "tests" / "data" / "opends-tasks"
HUD_LEFT = 0.68
TASKS = ("LaneChangeTest", "ThreeVehiclePlatoon", "MotorwayTask", "init_drive")


def _world(name: str) -> Any:
    from opends_gym.sim.world import World
    from opends_gym.task.bundled import BUNDLED_DIR

    folder = {
        "MotorwayTask": CORPUS / "opends-cts" / "MotorwayTask",
        "init_drive": CORPUS / "opends2023-annegretj" / "init_drive",
    }.get(name, BUNDLED_DIR / name)
    world = World(folder)
    if name == "LaneChangeTest":  # drive until the first lane signs are up, about 40 m ahead
        while not any(o.visible for o in world.objects.objects) and world.t_s < 60.0:
            world.run(0.5)
    world.triggers.weather["fog_percent"] = -1.0
    return world


def probes(world: Any, viewer: Any, width: int, height: int) -> dict[str, tuple[float, float, tuple[int, int, int] | None]]:
    """{name: (px, py, expected RGB or None for 'a car's lit body')} for the main camera."""
    from opends_gym.render import palette as pal

    view = viewer.composer.view
    cam = view.camera(width, height)
    out: dict[str, tuple[float, float, tuple[int, int, int] | None]] = {}

    def project(p: tuple[float, float, float]) -> tuple[float, float]:
        px = cam.project(cam.to_view(np.asarray([p], float)), width, height)[0]
        return float(px[0]), float(px[1])

    road = view.stage.road
    centres = [r.centre for r in road.ribbons if r.color == pal.ASPHALT]
    if road.bands:
        s = world.ego.state
        centres.append(np.array([[0.5 * (b.x_min + b.x_max), s.z - 14.0] for b in road.bands]))
    if centres:  # the road centre point 8..40 m ahead nearest the middle of the view
        xz = np.concatenate(centres)
        pts = np.stack([xz[:, 0], np.full(len(xz), world.ego.state.y), xz[:, 1]], axis=1)
        depth = cam.to_view(pts)[:, 2]
        ok = np.flatnonzero((depth > 8.0) & (depth < 40.0))
        px = cam.project(cam.to_view(pts[ok]), width, height) if len(ok) else np.zeros((0, 2))
        px = px[(px[:, 0] > 0) & (px[:, 0] < HUD_LEFT * width)]  # clear of the dials, bottom right
        if len(px):
            k = int(np.argmin(np.abs(px[:, 0] - 0.5 * width)))
            out["road"] = (float(px[k, 0]), float(px[k, 1]), pal.ASPHALT)
    if road.bands:  # the LCT's solid outer edge line, 25 m ahead
        edge = next(e for e, dashed in road.band_marks if not dashed)
        s = world.ego.state
        out["marking"] = (*project((edge, s.y, s.z - 25.0)), pal.MARKING)
    s = world.ego.state
    signs = [
        o
        for o in world.objects.objects
        if o.visible and "sign" in _key(world, o) and math.hypot(o.position[0] - s.x, o.position[2] - s.z) < 80.0
    ]
    if signs:
        s = world.ego.state
        o = min(signs, key=lambda o: math.hypot(o.position[0] - s.x, o.position[2] - s.z))
        parts = view.scene.parts(o)
        board = parts[-1]
        from opends_gym.render.styles import base_y

        out["sign"] = (*project((o.position[0], base_y(o) + 0.5 * (board.y0 + board.y1), o.position[2])), board.color)
    tr = world.traffic
    if tr is not None and len(tr.ids):
        s = world.ego.state
        pos = np.asarray(tr.positions, float)
        ahead = [(i, p) for i, p in enumerate(pos) if tr.is_car[i] and cam.to_view(p[None])[0][2] > 5.0]
        if ahead:
            i, p = min(ahead, key=lambda ip: float(np.hypot(ip[1][0] - s.x, ip[1][2] - s.z)))
            out["car"] = (*project((p[0], p[1] + 0.25 * 1.45 + 0.2, p[2])), pal.TRAFFIC_BODIES[i % len(pal.TRAFFIC_BODIES)])
    return out


def _key(world: Any, o: Any) -> str:
    models = world.task.scene.models
    return ((models[o.index].key if 0 <= o.index < len(models) else "") or "").lower()


def shoot(name: str, width: int, height: int, path: Path | None = None) -> tuple[np.ndarray, dict[str, Any]]:
    """Draw `name` in the drive window; returns the window's pixels (h, w, 3) and the probes."""
    from opends_gym.human.view_state import Overlay, ViewState
    from opends_gym.human.viewer import make_viewer
    from opends_gym.render import _pg

    world = _world(name)
    viewer = make_viewer(world, world.task.settings, width, height, title=f"opends-gym {name}")
    try:
        viewer.draw(Overlay(view=ViewState(camera_mode="ego", mirror=True)))
        frame = _pg.to_array(viewer.surface)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            viewer.save_png(str(path))
        return frame, probes(world, viewer, width, height)
    finally:
        viewer.close()
        world.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1280x720", help="window size WxH")
    ap.add_argument("--tasks", nargs="*", default=list(TASKS))
    args = ap.parse_args(argv)
    if not os.environ.get("DISPLAY"):
        print("no X display: run under xvfb-run", file=sys.stderr)
        return 2
    w, h = (int(v) for v in args.size.split("x"))
    for name in args.tasks:
        path = OUT / f"{name}.png"
        shoot(name, w, h, path)
        print(path.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
