"""Move a replayed World to any physics step of a recording, forwards and backwards.

Why: the Drive Analyzer's visual half steps through a drive in both directions. A World
cannot step backwards, so one exact forward replay (the recorded env, fed the recorded
actions, as `opends_gym.record.replay` does) leaves a keyframe (`World.get_state()`) every
`keyframe_every_s`; a seek restores the nearest keyframe at or before the target and steps
the World forward with the recorded `/controls`. For tasks whose env hooks only measure
(DrivingTask, ReactionTest, LCT, brake, DRT) every position is exact; ConTRe's and the
platoon's env-driven objects are exact at keyframes and re-simulated World-only between.
"""

from __future__ import annotations

import bisect
from pathlib import Path
from typing import Any

from ..record import messages as rec_msgs
from ..record.mcap_io import Recording, read_recording
from ..record.replay import replay_to
from ..record.schemas import ACTIONS, CONTROLS, EGO


class RecordingCursor:
    """A recording as a World that can be put at any step (see the module docstring)."""

    def __init__(self, path: str | Path | Recording, keyframe_every_s: float = 2.0) -> None:
        self.recording = path if isinstance(path, Recording) else read_recording(path)
        rec = self.recording
        self.controls = [rec_msgs.controls_from_message(m) for m in rec.topic(CONTROLS)]
        if not self.controls:
            raise ValueError(f"{rec.path}: the recording has no /controls; nothing to replay")
        start = replay_to(rec, 0.0)
        self.result = start
        self.world: Any = start.world
        self.env = start.env
        self.start_step = self.world.step_count
        every = max(1, int(round(keyframe_every_s / self.world.dt_s)))
        self._keys: list[int] = [self.world.step_count]
        self._states: list[dict[str, Any]] = [self.world.get_state()]
        if self.env is not None:
            for msg in rec.topic(ACTIONS):
                _, _, terminated, truncated, _ = self.env.step(rec_msgs.action_from_message(msg))
                if self.world.step_count - self._keys[-1] >= every:
                    self._keys.append(self.world.step_count)
                    self._states.append(self.world.get_state())
                if terminated or truncated:
                    break
        else:
            for i, c in enumerate(self.controls):
                self.world.step(c)
                if (i + 1) % every == 0:
                    self._keys.append(self.world.step_count)
                    self._states.append(self.world.get_state())
        self.last_step = self.start_step + len(self.controls)
        ego = rec.topic(EGO)
        self.path_xyz = [(float(e["x_m"]), float(e["y_m"]), float(e["z_m"])) for e in ego]
        self.ideal_tracks = {tid: poly.xz.tolist() for tid, (poly, _w) in self.world.road.ideal_tracks.items()}
        self.seek(self.start_step)

    @property
    def step(self) -> int:
        return int(self.world.step_count)

    @property
    def dt_s(self) -> float:
        return float(self.world.dt_s)

    def seek(self, step: int) -> None:
        """Put the World at physics step `step` (clamped to the recording)."""
        step = max(self.start_step, min(self.last_step, int(step)))
        if step < self.world.step_count or step - self.world.step_count > self._keys[-1] - self._keys[0]:
            i = bisect.bisect_right(self._keys, step) - 1
            self.world.set_state(self._states[i])
        elif step > self.world.step_count:
            i = bisect.bisect_right(self._keys, step) - 1
            if self._keys[i] > self.world.step_count:  # a keyframe is nearer than where we are
                self.world.set_state(self._states[i])
        while self.world.step_count < step:
            self.world.step(self.controls[self.world.step_count - self.start_step])

    def seek_time(self, t_s: float) -> None:
        self.seek(int(round(t_s / self.dt_s)))

    def close(self) -> None:
        self.result.close()
