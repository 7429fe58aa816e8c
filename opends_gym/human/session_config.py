"""What `opends-gym drive` was asked to do: a frozen config and the `--input` grammar.

Why: the CLI, scripted sessions and tests build the same `DriveConfig`; typos in an
input spec are errors with the accepted forms spelled out, not a silently idle car.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

INPUT_KINDS = ("keyboard", "joystick", "can-tcp", "can-bus")


@dataclass(frozen=True)
class InputSpec:
    """One `--input`: keyboard | joystick | can-tcp[:HOST:PORT] | can-bus[:IFACE:CHANNEL]."""

    kind: str
    host: str | None = None
    port: int | None = None
    interface: str | None = None
    channel: str | None = None

    def __str__(self) -> str:
        if self.kind == "can-tcp" and self.host:
            return f"can-tcp:{self.host}:{self.port}"
        if self.kind == "can-bus" and self.interface:
            return f"can-bus:{self.interface}:{self.channel}"
        return self.kind


def parse_input_spec(text: str) -> InputSpec:
    kind, _, rest = text.strip().partition(":")
    kind = kind.lower()
    if kind not in INPUT_KINDS:
        raise ValueError(f"unknown input {text!r}; use keyboard, joystick, can-tcp[:HOST:PORT] or can-bus[:IFACE:CHANNEL]")
    if kind in ("keyboard", "joystick"):
        if rest:
            raise ValueError(f"input {kind} takes no options (got {text!r})")
        return InputSpec(kind)
    if kind == "can-tcp":
        if not rest:
            return InputSpec(kind)  # ip and port from settings.xml CANInterface
        host, _, port = rest.rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise ValueError(f"can-tcp needs HOST:PORT with a port 1..65535 (got {text!r})")
        return InputSpec(kind, host=host, port=int(port))
    if not rest:
        return InputSpec(kind, interface="socketcan", channel="can0")
    iface, _, channel = rest.partition(":")
    if not iface or not channel:
        raise ValueError(f"can-bus needs IFACE:CHANNEL, e.g. can-bus:socketcan:can0 or can-bus:virtual:test (got {text!r})")
    return InputSpec(kind, interface=iface, channel=channel)


@dataclass(frozen=True)
class DriveConfig:
    """A human driving session. Units in the names; see `opends-gym drive --help`."""

    target: str = "OpenDS/LaneChangeTest-v0"
    inputs: tuple[InputSpec, ...] = (InputSpec("keyboard"),)
    record_path: str | None = None
    record_video_hz: float | None = None  # also record the driver's view at this rate (foxglove.CompressedImage)
    video_format: str = "png"
    driver: str | None = None
    duration_s: float | None = None
    window: bool = True
    fast: bool = False
    seed: int = 0
    physics: str = "fast"
    physics_hz: float = 60.0
    width: int = 1280
    height: int = 720
    calibration: str | None = None
    dbc: str | None = None
    settings_server: bool | None = None  # None: settings.xml settingsControllerServer/startServer
    server_host: str = "127.0.0.1"
    server_port: int | None = None  # None: settings.xml port
    server_control_peers: tuple[str, ...] | None = None  # None: any peer may send control events
    server_token_env: str | None = None  # environment variable holding the control token
    audio: bool = True
    max_catch_up_steps: int = 6
    screenshot_path: str | None = None  # save the last frame as PNG when the drive ends
    hold_on_instructions: bool | None = None  # None: only when a window shows them
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.duration_s is not None and not self.duration_s > 0:
            raise ValueError("duration_s must be positive")
        if not self.physics_hz > 0:
            raise ValueError("physics_hz must be positive")
        if not self.inputs:
            raise ValueError("a drive needs at least one input")
