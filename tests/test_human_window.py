"""The drive window under a virtual X server (Xvfb): a real window, real pygame events,
captured to PNG and checked to show the road and the HUD."""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent

# Runs in a subprocess with DISPLAY set: the ReactionTest opens an instruction screen at
# start; Return is posted to the window's event queue to close it, then the Up arrow is
# held; the last frame is saved with --screenshot's code path.
SCRIPT = r"""
import json, sys
import pygame
from opends_gym.human import viewer as V
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig, InputSpec

calls = [0]
original = V.DriveViewer.events

def events(self):
    calls[0] += 1
    if calls[0] == 20:
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RETURN, mod=0, unicode="\r", scancode=40))
    if calls[0] == 21:
        pygame.event.post(pygame.event.Event(pygame.KEYUP, key=pygame.K_RETURN, mod=0, unicode="\r", scancode=40))
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_UP, mod=0, unicode="", scancode=82))
    return original(self)

V.DriveViewer.events = events
cfg = DriveConfig(target="ReactionTest", inputs=(InputSpec("keyboard"),), duration_s=2.5, width=800, height=450,
                  screenshot_path=sys.argv[1], audio=False)
with DriveSession(cfg) as s:
    r = s.run()
    speed = s.snapshot.speed_kmh
print(json.dumps({"frames": r.frames, "sim_time_s": r.sim_time_s, "wall_s": r.wall_s, "holds": r.holds, "speed_kmh": speed,
                  "end": r.end_reason}))
"""


@pytest.fixture
def xvfb_display():  # type: ignore[no-untyped-def]
    exe = shutil.which("Xvfb")
    assert exe is not None, "Xvfb is needed for the window test (scripts/test.sh installs the xvfb package)"
    for _ in range(20):
        n = random.randint(100, 999)
        if not Path(f"/tmp/.X{n}-lock").exists():
            break
    cmd = [exe, f":{n}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 15.0
        while not Path(f"/tmp/.X11-unix/X{n}").exists():
            assert proc.poll() is None, "Xvfb exited at start"
            assert time.monotonic() < end, "Xvfb did not come up"
            time.sleep(0.05)
        yield f":{n}"
    finally:
        proc.terminate()
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            proc.kill()


def test_window_shows_road_and_hud(xvfb_display: str, tmp_path: Path) -> None:
    shot = tmp_path / "drive.png"
    env = {**os.environ, "DISPLAY": xvfb_display, "SDL_VIDEODRIVER": "x11", "SDL_AUDIODRIVER": "dummy"}
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(shot)], env=env, cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["end"] == "time limit" and out["sim_time_s"] == pytest.approx(2.5)
    assert [reason.split(" -")[0] for _, reason in out["holds"]] == ["Instructions: instructionScreen_1"]
    assert out["speed_kmh"] > 20.0  # the Up arrow, read from the window's event queue, drove the car
    assert out["wall_s"] >= 2.4 and out["frames"] >= 10

    import pygame

    img = pygame.image.load(str(shot))
    assert img.get_size() == (800, 450)
    rgb = pygame.surfarray.array3d(img).transpose(1, 0, 2).astype(int)  # (h, w, 3)
    lower = rgb[300:, :500]
    grey = (np.abs(lower[..., 0] - lower[..., 2]) < 12) & (lower.mean(axis=2) > 25) & (lower.mean(axis=2) < 140)
    assert grey.mean() > 0.3, "no road surface in the lower half of the window"
    sky = rgb[:60, 300:500]
    assert sky[..., 2].mean() > 150 and sky[..., 2].mean() > sky[..., 0].mean() + 30, "the sky is dark: the instruction screen is still up"
    dials = rgb[330:, 560:]
    face = (np.abs(dials - np.array([20, 20, 24])).max(axis=2) <= 8).mean()
    bright = (dials.min(axis=2) > 200).mean()
    assert face > 0.15 and bright > 0.002, f"no speedometer/rpm dials (face {face:.3f}, marks {bright:.4f})"


REPLAY_SCRIPT = r"""
import sys
import pygame
from opends_gym.cli.main import main
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig
from opends_gym.render import window as W

cfg = DriveConfig(target="ReactionTest", window=False, fast=True, duration_s=4.0, record_path=sys.argv[1])
with DriveSession(cfg) as s:
    s.sources.keyboard.handle_key("KEY_UP", True)
    s.sources.keyboard.handle_key("KEY_LEFT", True)
    s.run()
calls = [0]
original = W.FrameWindow.pump

def pump(self):
    calls[0] += 1
    if calls[0] == 3:
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_RETURN, mod=0, unicode="\r", scancode=40))
    if calls[0] == 40:
        pygame.image.save(self.screen, sys.argv[2])
        pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_ESCAPE, mod=0, unicode="", scancode=41))
    return original(self)

W.FrameWindow.pump = pump
sys.exit(main(["replay", sys.argv[1], "--view"]))
"""


def test_replay_view_window(xvfb_display: str, tmp_path: Path) -> None:
    rec, shot = tmp_path / "drive.mcap", tmp_path / "replay.png"
    env = {**os.environ, "DISPLAY": xvfb_display, "SDL_VIDEODRIVER": "x11", "SDL_AUDIODRIVER": "dummy"}
    proc = subprocess.run(
        [sys.executable, "-c", REPLAY_SCRIPT, str(rec), str(shot)], env=env, cwd=ROOT, capture_output=True, text=True, timeout=180
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    import pygame

    from opends_gym.human.replay_view import PATH_COLOUR

    rgb = pygame.surfarray.array3d(pygame.image.load(str(shot))).transpose(1, 0, 2).astype(int)
    assert (np.abs(rgb - np.array(PATH_COLOUR)).max(axis=2) <= 10).mean() > 0.001, "the driven path is not drawn"
