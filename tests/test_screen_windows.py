"""One window per OpenDS screen (`numberOfScreens`) under a virtual X server: each window
shows its own screen's slice of the wide frame, placed side by side."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from .test_human_window import xvfb_display  # noqa: F401  (the Xvfb fixture)

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = r"""
import dataclasses, json
import numpy as np
import pygame
from opends_gym.human.view_state import Overlay
from opends_gym.human.viewer import DriveViewer
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR

world = World(BUNDLED_DIR / "LaneChangeTest")
world.run(1.0)
s = world.task.settings
three = dataclasses.replace(s, general=dataclasses.replace(s.general, number_of_screens=3))
viewer = DriveViewer(world, three, 480, 180, window_per_screen=True)
viewer.draw(Overlay())
wins = viewer.window.windows
wide = pygame.surfarray.array3d(viewer.surface).transpose(1, 0, 2)
slices = [pygame.surfarray.array3d(w.get_surface()).transpose(1, 0, 2) for w in wins]
print(json.dumps({
    "windows": len(wins), "sizes": [list(w.size) for w in wins], "x": [w.position[0] for w in wins],
    "wide": list(wide.shape), "match": [bool((sl == wide[:, 160 * i : 160 * (i + 1)]).all()) for i, sl in enumerate(slices)],
    "differ": bool((slices[0] != slices[2]).any()),
}))
viewer.close()
"""


def test_one_window_per_screen_shows_its_slice(xvfb_display: str) -> None:  # noqa: F811
    env = {**os.environ, "DISPLAY": xvfb_display, "SDL_VIDEODRIVER": "x11", "SDL_AUDIODRIVER": "dummy"}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["windows"] == 3 and out["sizes"] == [[160, 180]] * 3
    assert out["x"] == [0, 160, 320]  # side by side, as the screens' cameras turn
    assert out["wide"] == [180, 480, 3] and out["match"] == [True, True, True]
    assert out["differ"]  # the left and right screens look different ways
