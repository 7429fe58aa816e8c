"""`opends-gym replay REC --view`: a recorded session played in the viewer, stepped both
ways (exactly), with the driven path and the ideal track drawn and the state shown."""

from __future__ import annotations

import numpy as np
import pytest

from opends_gym.human.replay_view import IDEAL_COLOUR, PATH_COLOUR, ReplayViewer
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig
from opends_gym.record.replay import replay_to
from tests.human_helpers import reaction_test_with_ideal_track


@pytest.fixture
def recording(task_copy, tmp_path):  # type: ignore[no-untyped-def]
    folder = reaction_test_with_ideal_track(task_copy)
    cfg = DriveConfig(target=str(folder), window=False, fast=True, duration_s=6.0, record_path=str(tmp_path / "drive.mcap"))
    with DriveSession(cfg) as s:
        s.sources.keyboard.handle_key("KEY_UP", True)
        result = s.run()
    return result.recordings[0]


def colour_share(frame: np.ndarray, colour: tuple[int, int, int]) -> float:
    return float((np.abs(frame.astype(int) - np.array(colour)).max(axis=2) <= 10).mean())


def test_stepping_back_and_forth_is_exact(recording: str) -> None:
    viewer = ReplayViewer(recording, 480, 270, window=False)
    try:
        c = viewer.cursor
        assert (c.start_step, c.last_step) == (0, 360)
        viewer.handle_key("KEY_END")
        for key in ("KEY_DOWN", "KEY_LEFT", "KEY_PGDN", "KEY_UP", "KEY_RIGHT", "KEY_RIGHT"):
            viewer.handle_key(key)
        assert c.step == 60 + 6  # End -> 360, -1 s, -0.05 s, -10 s (clamped to 0), +1 s, +2 x 0.05 s
        for step in (300, 66, 250, 1, 359):
            c.seek(step)
            fresh = replay_to(recording, step * c.dt_s)
            try:
                assert fresh.world.step_count == step
                assert c.world.ego.get_state()["body"] == fresh.world.ego.get_state()["body"]
                assert len(c.world.events) == len(fresh.world.events)
            finally:
                fresh.close()
        lines = viewer.state_lines()
        assert lines[0].startswith("t     5.98 s   step 359 / 360") and "km/h" in lines[1]
    finally:
        viewer.close()


def test_path_and_ideal_track_are_drawn_and_playback_moves(recording: str) -> None:
    viewer = ReplayViewer(recording, 480, 270, window=False)
    try:
        viewer.cursor.seek(180)
        frame = viewer.frame()
        assert colour_share(frame, PATH_COLOUR) > 0.002 and colour_share(frame, IDEAL_COLOUR) > 0.002
        viewer.handle_key("KEY_2")  # lines off
        frame = viewer.frame()
        assert colour_share(frame, PATH_COLOUR) < 0.0005 and colour_share(frame, IDEAL_COLOUR) < 0.0005
        viewer.handle_key("KEY_SPACE")
        assert viewer.playing
        viewer.advance(0.5)
        assert viewer.cursor.step == 210
        viewer.advance(100.0)
        assert viewer.cursor.step == 360 and not viewer.playing  # stops at the end
        viewer.handle_key("KEY_V")
        assert viewer.composer.view.camera_mode == "chase"
    finally:
        viewer.close()
