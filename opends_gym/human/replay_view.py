"""`opends-gym replay REC --view`: the Drive Analyzer's visual half.

Why: after a session the experimenter looks at the drive: where the car went against the
ideal track, what the participant did at each moment, which trial fired when. The
recording is replayed exactly (`RecordingCursor`) and drawn in the participant's viewer
(`opends_gym.render.compose.ViewComposer`, looking down from above by default) with the driven path
(orange) and the ideal tracks (cyan) laid on the ground, and a panel with the state at the
cursor. Keys (as OpenDS's analyzer where it has one): Return/Space play or pause;
Right/Left one data point (0.05 s) on or back; Up/Down one second; PgUp/PgDn ten seconds;
Home/End start/end; V camera; 2 path lines on/off; Escape/Q quit.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np

from .replay_cursor import RecordingCursor

REPLAY_CAMERAS = ("top", "chase", "ego", "static_back")
PATH_COLOUR = (255, 140, 30)
IDEAL_COLOUR = (40, 210, 230)
DATA_POINT_S = 0.05  # OpenDS records at 20 Hz
KEY_JUMPS_S = {"KEY_RIGHT": DATA_POINT_S, "KEY_LEFT": -DATA_POINT_S, "KEY_UP": 1.0, "KEY_DOWN": -1.0, "KEY_PGUP": 10.0, "KEY_PGDN": -10.0}


class ReplayViewer:
    """Plays a recording in the viewer; `handle_key` and `frame` work without a window."""

    def __init__(self, recording: str | Path, width: int = 1280, height: int = 720, window: bool = True, camera_mode: str = "top") -> None:
        from ..render.compose import ViewComposer

        self.cursor = RecordingCursor(recording)
        self.width, self.height = width, height
        self.window: Any = None
        if window:
            from ..render.window import FrameWindow

            self.window = FrameWindow(width, height, title=f"opends-gym replay: {Path(str(recording)).name}")
        self.composer = ViewComposer(self.cursor.world, self.cursor.world.task.settings, camera_mode=camera_mode)
        self.playing = False
        self.show_lines = True
        self.quit = False
        self._surface: Any = None

    # ------------------------------------------------------------------ control
    def handle_key(self, key: str) -> None:
        """A key press (jME name, as the drive uses)."""
        c = self.cursor
        if key in ("KEY_RETURN", "KEY_SPACE"):
            self.playing = not self.playing
        elif key in KEY_JUMPS_S:
            self.playing = False
            c.seek(c.step + int(round(KEY_JUMPS_S[key] / c.dt_s)))
        elif key == "KEY_HOME":
            c.seek(c.start_step)
        elif key == "KEY_END":
            c.seek(c.last_step)
        elif key == "KEY_V":
            view = self.composer.view
            view.camera_mode = REPLAY_CAMERAS[(REPLAY_CAMERAS.index(view.camera_mode) + 1) % len(REPLAY_CAMERAS)]
        elif key == "KEY_2":
            self.show_lines = not self.show_lines
        elif key in ("KEY_ESCAPE", "KEY_Q"):
            self.quit = True

    def advance(self, wall_dt_s: float) -> None:
        """While playing, move on by `wall_dt_s` of simulated time; stop at the end."""
        if self.playing:
            c = self.cursor
            c.seek(c.step + max(1, int(round(wall_dt_s / c.dt_s))))
            if c.step >= c.last_step:
                self.playing = False

    # ------------------------------------------------------------------ drawing
    def state_lines(self) -> list[str]:
        from ..record.replay import describe_state

        s = describe_state(self.cursor.world)
        c = self.cursor
        lines = [
            f"t {s['t_s']:8.2f} s   step {s['step']} / {c.last_step}   {'PLAYING' if self.playing else 'PAUSED'}",
            f"x {s['x_m']:9.2f}  z {s['z_m']:10.2f}  speed {s['speed_kmh']:6.1f} km/h  lane {s['lane']}",
            f"steer {s['steering']:+.3f}  gas {s['accelerator']:.2f}  brake {s['brake']:.2f}  gear {s['gear']}  rpm {s['rpm']:.0f}",
        ]
        if s.get("last_reaction"):
            lines.append(f"last reaction: {s['last_reaction']}")
        events = [e for e in self.cursor.world.events if e.kind in ("trigger", "reaction", "message")]
        if events:
            e = events[-1]
            lines.append(f"last event: {e.t_s:.2f} s {e.kind} {e.source}")
        return lines

    def _draw_lines(self, surface: Any) -> None:
        from ..render import _pg

        pg = _pg.pygame()
        view = self.composer.view
        w, h = surface.get_size()
        cam = view.camera(w, h)
        ground = float(self.cursor.world.ego.state.y)
        lines = [(np.array(self.cursor.path_xyz, dtype=float), PATH_COLOUR)]
        for xz in self.cursor.ideal_tracks.values():
            a = np.array(xz, dtype=float)
            lines.append((np.stack([a[:, 0], np.full(len(a), ground), a[:, 1]], axis=1), IDEAL_COLOUR))
        for pts, colour in lines:
            if len(pts) < 2:
                continue
            v = cam.to_view(pts + np.array([0.0, 0.05, 0.0]))
            near = cam.near + 0.1
            for a, b in itertools.pairwise(v):
                if a[2] < near and b[2] < near:
                    continue
                if a[2] < near or b[2] < near:  # clip the segment at the near plane
                    t = (near - a[2]) / (b[2] - a[2])
                    cut = a + t * (b - a)
                    a, b = (cut, b) if a[2] < near else (a, cut)
                p = cam.project(np.stack([a, b]), w, h)
                if np.all(np.isfinite(p)) and np.abs(p).max() < 1e5:
                    pg.draw.line(surface, colour, p[0].tolist(), p[1].tolist(), 3)

    def draw(self, surface: Any) -> None:
        from ..render import _pg

        self.composer.draw(surface)
        if self.show_lines:
            self._draw_lines(surface)
        h = surface.get_size()[1]
        size = max(12, h // 40)
        for i, line in enumerate(self.state_lines()):
            _pg.text(surface, line, (10, 10 + i * (size + 2)), size, (255, 255, 255))

    def frame(self) -> np.ndarray:
        """The current view as an (h, w, 3) uint8 array (no window needed)."""
        from ..render import _pg

        if self._surface is None:
            self._surface = _pg.new_surface(self.width, self.height)
        self.draw(self._surface)
        return _pg.to_array(self._surface)

    # ------------------------------------------------------------------ window loop
    def run(self, fps: float = 30.0) -> None:
        from ..render import _pg
        from .inputs.keys import jme_key_name

        if self.window is None:
            raise RuntimeError("run() needs a window (window=True)")
        pg = _pg.pygame()
        while not self.quit and self.window.is_open:
            for ev in self.window.pump():
                if ev.type == pg.QUIT:
                    self.quit = True
                elif ev.type == pg.KEYDOWN:
                    name = jme_key_name(int(ev.key))
                    if name is not None:
                        self.handle_key(name)
            self.draw(self.window.screen)
            pg.display.flip()
            dt = self.window.clock.tick(fps) / 1000.0
            self.advance(dt if math.isfinite(dt) else 1.0 / fps)

    def close(self) -> None:
        if self.window is not None:
            self.window.close()
        self.cursor.close()


def view_recording(path: str | Path, width: int = 1280, height: int = 720, start_s: float = 0.0) -> int:
    """Entry point of `opends-gym replay REC --view [--at SECONDS]`."""
    viewer = ReplayViewer(path, width, height)
    viewer.cursor.seek_time(start_s)
    try:
        viewer.run()
    finally:
        viewer.close()
    return 0
