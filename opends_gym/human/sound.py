"""playSound / pauseSound / stopSound in a human session: played where audio exists, always logged.

Why: reaction tasks give feedback by sound (ReactionTest's `good` and `fail`). The trigger
core only records "sound" events (the simulation has no speakers); the runner hands them
here. Each is logged (and kept in `log`, which the session reports) whether or not it
could be heard: the file may be missing (tasks rarely ship OpenDS's assets) or the machine
may have no audio device. pygame.mixer is started on the first sound and any failure
turns playback off for the session with one warning.
"""

from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)
ASSET_ROOT_HOPS = (0, 1, 2, 3, 4)  # task folder, then up to OpenDS's assets/ root


@dataclass(frozen=True)
class SoundLogEntry:
    t_s: float
    sound_id: str
    op: str  # play | pause | stop
    played: bool
    reason: str = ""


def find_sound(task_folder: Path, key: str, extra_roots: tuple[Path, ...] = ()) -> Path | None:
    """A sound file beside the task, at the OpenDS asset root, or under an extra root."""
    if not key:
        return None
    roots = [task_folder]
    base = task_folder
    for _ in range(max(ASSET_ROOT_HOPS)):
        base = base.parent
        roots.append(base)
    for root in [*extra_roots, *roots]:
        p = root / key
        if p.is_file():
            return p
    return None


class SoundPlayer:
    """Plays the scene's sounds by id (see the module docstring)."""

    def __init__(self, task: Any, enabled: bool = True, asset_roots: tuple[Path, ...] = ()) -> None:
        self.enabled = enabled
        self.sounds = {s.id: s for s in task.scene.sounds}
        self.paths = {s.id: find_sound(Path(task.folder), s.key, asset_roots) for s in task.scene.sounds}
        self.log: list[SoundLogEntry] = []
        self._mixer_ok: bool | None = None
        self._loaded: dict[str, Any] = {}
        self._channels: dict[str, Any] = {}

    def _mixer(self) -> bool:
        if self._mixer_ok is None:
            try:
                import pygame

                if not pygame.mixer.get_init():
                    pygame.mixer.init()
                self._mixer_ok = True
            except Exception as e:  # no audio device, no driver: log once, keep logging sounds
                log.warning("no audio output (%s); sounds are logged but not played", e)
                self._mixer_ok = False
        return self._mixer_ok

    def handle(self, t_s: float, sound_id: str, op: str) -> SoundLogEntry:
        """React to one "sound" event of the World."""
        played, reason = self._do(sound_id, op)
        entry = SoundLogEntry(t_s, sound_id, op, played, reason)
        self.log.append(entry)
        log.info("sound %s %s at %.3f s%s", op, sound_id, t_s, "" if entry.played else f" (not heard: {entry.reason})")
        return entry

    def _do(self, sound_id: str, op: str) -> tuple[bool, str]:
        if not self.enabled:
            return False, "audio disabled"
        if op in ("stop", "pause"):
            ch = self._channels.get(sound_id)
            if ch is not None:
                try:
                    ch.stop() if op == "stop" else ch.pause()
                except Exception as e:
                    return False, str(e)
            return True, ""
        if sound_id not in self.sounds:
            return False, "no such sound in scene.xml"
        path = self.paths.get(sound_id)
        if path is None:
            return False, f"file '{self.sounds[sound_id].key}' not found"
        if not self._mixer():
            return False, "no audio output"
        try:
            import pygame

            snd = self._loaded.get(sound_id)
            if snd is None:
                snd = pygame.mixer.Sound(str(path))
                spec = self.sounds[sound_id]
                snd.set_volume(max(0.0, min(1.0, float(spec.volume))))
                self._loaded[sound_id] = snd
            self._channels[sound_id] = snd.play(loops=-1 if self.sounds[sound_id].loop else 0)
            return True, ""
        except Exception as e:  # an unreadable file must not stop the drive
            return False, f"{type(e).__name__}: {e}"

    def close(self) -> None:
        if self._mixer_ok:
            import pygame

            with contextlib.suppress(Exception):
                pygame.mixer.stop()
