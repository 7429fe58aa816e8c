"""What the participant's screen should show, apart from the World itself.

Why: OpenDS's display keys (toggle_cam, toggle_backmirror, toggle_topview,
toggle_messagebox, toggle_keymapping, toggle_stats, the weather keys) change only the
view, never the simulation; keeping them here (not in the World) keeps recordings and
replays free of them. `Overlay` is what the runner hands the viewer each frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

# toggle_cam cycles these: OpenDS's SimulatorCam.changeCamera goes ego -> chase -> top -> outside
# (the fixed `outsideCamPosition` camera) -> ego; static_back (a settings-only mode there) stays last
CAMERA_MODES = ("ego", "chase", "top", "outside", "static_back")
WEATHER_KEYS = {
    "snow_inc5": ("snowing_percent", 5.0),
    "snow_dec5": ("snowing_percent", -5.0),
    "rain_inc5": ("raining_percent", 5.0),
    "rain_dec5": ("raining_percent", -5.0),
    "fog_inc5": ("fog_percent", 5.0),
    "fog_dec5": ("fog_percent", -5.0),
}
FOREVER_S = 1e9


@dataclass
class ViewState:
    camera_mode: str = "ego"
    mirror: bool = True
    top_view: bool = False
    show_messages: bool = True
    show_key_mapping: bool = False
    show_stats: bool = False
    headlights: bool = True  # the low beam, seen only at night (render/night.py); toggle_headlight (OpenDS: KEY_L)
    weather_offset: dict[str, float] = field(default_factory=dict)
    _messages: list[tuple[str, float]] = field(default_factory=list)  # (text, until, wall clock)

    @classmethod
    def from_settings(cls, settings: Any) -> ViewState:
        g = settings.general
        mode = g.camera_mode if g.camera_mode in CAMERA_MODES else "ego"
        return cls(camera_mode=mode, mirror=(g.mirror_mode or "off") != "off", top_view=False, show_stats=bool(g.show_stats))

    def command(self, cmd: str) -> bool:
        """Apply a display function; False when it is not a display function."""
        if cmd == "toggle_cam":
            self.camera_mode = CAMERA_MODES[(CAMERA_MODES.index(self.camera_mode) + 1) % len(CAMERA_MODES)]
        elif cmd == "toggle_backmirror":
            self.mirror = not self.mirror
        elif cmd == "toggle_topview":
            self.top_view = not self.top_view
        elif cmd == "toggle_messagebox":
            self.show_messages = not self.show_messages
        elif cmd == "toggle_keymapping":
            self.show_key_mapping = not self.show_key_mapping
        elif cmd == "toggle_stats":
            self.show_stats = not self.show_stats
        elif cmd == "toggle_headlight":
            self.headlights = not self.headlights
        elif cmd in WEATHER_KEYS:
            name, delta = WEATHER_KEYS[cmd]
            self.weather_offset[name] = self.weather_offset.get(name, 0.0) + delta
        else:
            return False
        return True

    def weather(self, base: dict[str, float]) -> dict[str, float]:
        """The World's weather with the participant's weather keys applied (0..100 %)."""
        out = dict(base)
        for k, d in self.weather_offset.items():
            out[k] = max(0.0, min(100.0, float(out.get(k, 0.0)) + d))
        return out

    def show_message(self, text: str, duration_s: float, now: float) -> None:
        self._messages.append((text, now + (duration_s if duration_s > 0 else FOREVER_S)))
        self._messages = self._messages[-5:]

    def messages(self, now: float) -> list[str]:
        self._messages = [(t, u) for t, u in self._messages if u > now]
        return [t for t, _ in self._messages] if self.show_messages else []


@dataclass
class Overlay:
    """Session state for one frame: holds, device messages, status lines."""

    hold: str = ""
    instruction: str | None = None
    paused: bool = False
    messages: list[str] = field(default_factory=list)
    status: list[str] = field(default_factory=list)
    view: ViewState = field(default_factory=ViewState)
    snapshot: Any = None
