"""The drive window under Xvfb shows the road, its markings, a sign and a car where the camera
should see them: world points projected with the window camera's lens (docs/gen_screenshots.py
`probes`), sampled in the window's own pixels."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from .test_human_window import xvfb_display  # noqa: F401  (fixture)

ROOT = Path(__file__).resolve().parents[1]
W, H = 480, 270
SCRIPT = r"""
import json, sys
sys.path.insert(0, "docs")
import gen_screenshots as g
W, H = int(sys.argv[1]), int(sys.argv[2])
out = {}
for name in ("LaneChangeTest", "ThreeVehiclePlatoon", "init_drive"):
    frame, probes = g.shoot(name, W, H)
    out[name] = {}
    for k, (x, y, c) in probes.items():
        patch = frame[max(0, int(y) - 3) : int(y) + 4, max(0, int(x) - 3) : int(x) + 4]
        out[name][k] = [x, y, list(c), patch.tolist()]
print(json.dumps(out))
"""


def _near(patch: list, color: list[int], tol: int) -> bool:
    px = np.asarray(patch, int).reshape(-1, 3)
    return bool((np.abs(px - np.asarray(color)).max(axis=1) <= tol).any())


def test_window_pixels_at_projected_points(xvfb_display: str) -> None:  # noqa: F811
    env = {**os.environ, "DISPLAY": xvfb_display, "SDL_VIDEODRIVER": "x11", "SDL_AUDIODRIVER": "dummy", "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(W), str(H)], env=env, cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    lct, tvpt, od = out["LaneChangeTest"], out["ThreeVehiclePlatoon"], out["init_drive"]
    for name, probes in out.items():
        assert "road" in probes, name
        assert _near(probes["road"][3], probes["road"][2], 0), f"{name}: no asphalt where the road centre projects"
    assert _near(lct["marking"][3], lct["marking"][2], 0), "the LCT's edge line is not where it projects"
    assert _near(tvpt["marking"][3], tvpt["marking"][2], 0), "the TVPT's edge line is not where it projects"
    # the nearest LCT lane sign: its board colour (under flat shading) or its white label, not sky or grass
    sign = lct["sign"]
    patch = np.asarray(sign[3], int)
    cy, cx = patch.shape[0] // 2, patch.shape[1] // 2
    board = patch[cy - 1 : cy + 2, cx - 1 : cx + 2].reshape(-1, 3)  # (the 3x3 centre: the board is a few pixels wide far off)
    blue = (board[:, 2] > board[:, 0] + 60) | (board.min(axis=1) > 235)
    assert blue.mean() > 0.8, f"no sign board at its projected point: {board[:5].tolist()}"
    # the platoon's lead car 30 m ahead: its body colour, shaded (0.62..1.0 of the base colour)
    car = tvpt["car"]
    body = np.asarray(car[3], float).reshape(-1, 3)
    base = np.asarray(car[2], float)
    ratio = body / np.maximum(base, 1.0)
    shaded = (ratio.min(axis=1) > 0.55) & (ratio.max(axis=1) < 1.05) & (np.ptp(ratio, axis=1) < 0.08)
    assert shaded.mean() > 0.5, f"no car body at the lead car's projected point: {body[:5].tolist()}"
    assert od["road"][2] == [96, 96, 100]
