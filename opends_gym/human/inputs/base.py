"""What every input device hands the human runner: a partial `InputFrame` and a status.

Why: a keyboard, a wheel, a CAN gateway, a CAN bus and the settings-controller server
each know only part of what a driver does (a wheel has no reset key; a CAN gateway may
send only the steering angle). Each source fills the fields it knows and leaves the rest
`None`; `merge_frames` lays them over each other in priority order, and the runner turns
the result into the one `DriverControls` the simulation understands. Toggles (cruise
control, engine, pause) stay toggles here and are resolved against the world's state by
the runner, so the recorded `DriverControls` are explicit and a replay is exact.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, fields, replace
from typing import Protocol, runtime_checkable


@dataclass(frozen=True)
class TrafficControl:
    """External control of a traffic car (settings-controller `SetVehicleControl`)."""

    vehicle_id: str
    steering: float
    accelerator: float
    brake: float


@dataclass(frozen=True)
class InputStatus:
    """How a source is doing, for the HUD and the log.

    `blocking` asks the runner to hold the drive (a wheel was unplugged): the simulation
    waits, with `message` on screen, until the source is back.
    """

    name: str
    connected: bool = True
    message: str = ""
    blocking: bool = False


@dataclass
class InputFrame:
    """A partial `DriverControls`: `None` means "this source has no opinion".

    Continuous values (steering -1..1 with + left, pedals 0..1) are levels held until
    changed; tuples and `True` flags are one-shot events of this poll. `commands` are
    OpenDS function ids the runner handles itself (toggle_pause, shutdown,
    close_instruction_screen, toggle_cam, ...). `messages` are (text, seconds) pairs to
    show on screen (the CAN gateway's `display`). A source that sets `steering` says
    with `steering_axis` whether it is a joystick axis (the only steering OpenDS's
    SteeringReactionTimer hears); left None, it is not.
    """

    steering: float | None = None
    steering_axis: bool | None = None
    accelerator: float | None = None
    brake: float | None = None
    clutch: float | None = None
    hand_brake: bool | None = None
    horn: bool | None = None
    turn_signal: str | None = None
    gear: int | None = None
    automatic: bool | None = None
    engine_on: bool | None = None
    reverse: bool | None = None
    reset_to: str | None = None
    shift_up: bool = False
    shift_down: bool = False
    toggle_automatic: bool = False
    toggle_engine: bool = False
    toggle_cruise: bool = False
    toggle_hand_brake: bool = False
    cruise_speed_delta_mps: float = 0.0
    keys: tuple[str, ...] = ()
    buttons: tuple[int, ...] = ()
    remote_triggers: tuple[str, ...] = ()
    commands: tuple[str, ...] = ()
    messages: tuple[tuple[str, float], ...] = ()
    traffic_controls: tuple[TrafficControl, ...] = ()

    def is_empty(self) -> bool:
        return self == InputFrame()


_LEVELS = (
    "steering",
    "steering_axis",
    "accelerator",
    "brake",
    "clutch",
    "hand_brake",
    "horn",
    "turn_signal",
    "gear",
    "automatic",
    "engine_on",
    "reverse",
    "reset_to",
)
_FLAGS = ("shift_up", "shift_down", "toggle_automatic", "toggle_engine", "toggle_cruise", "toggle_hand_brake")
_TUPLES = ("keys", "buttons", "remote_triggers", "commands", "messages", "traffic_controls")
assert set(_LEVELS + _FLAGS + _TUPLES + ("cruise_speed_delta_mps",)) == {f.name for f in fields(InputFrame)}


def merge_frames(frames: Iterable[InputFrame]) -> InputFrame:
    """Lay frames over each other: later frames win for levels; events accumulate."""
    out = InputFrame()
    for f in frames:
        updates: dict[str, object] = {}
        for name in _LEVELS:
            v = getattr(f, name)
            if v is not None:
                updates[name] = v
        if f.steering is not None:  # the steering's source comes with it
            updates["steering_axis"] = f.steering_axis
        for name in _FLAGS:
            if getattr(f, name):
                updates[name] = True
        for name in _TUPLES:
            v = getattr(f, name)
            if v:
                updates[name] = getattr(out, name) + tuple(v)
        if f.cruise_speed_delta_mps:
            updates["cruise_speed_delta_mps"] = out.cruise_speed_delta_mps + f.cruise_speed_delta_mps
        if updates:
            out = replace(out, **updates)  # type: ignore[arg-type]
    return out


def finite_or_none(value: float | None, lo: float, hi: float) -> float | None:
    """A level clamped into [lo, hi]; NaN and infinities become None (ignored)."""
    if value is None or not math.isfinite(value):
        return None
    return lo if value < lo else hi if value > hi else float(value)


@runtime_checkable
class InputSource(Protocol):
    """A device or connection that drives the car. Sources never import the env.

    `poll(t_s)` is called once per physics step with the simulation time and returns what
    happened since the last poll. Background I/O (sockets, buses) runs on the source's
    own threads and is handed over here, so the simulation stays deterministic given the
    same sequence of frames.
    """

    name: str

    def poll(self, t_s: float) -> InputFrame: ...

    def status(self) -> InputStatus: ...

    def close(self) -> None: ...


@dataclass
class InputCombiner:
    """Several sources as one, in priority order (later sources override levels)."""

    sources: list[InputSource] = field(default_factory=list)

    def add(self, source: InputSource) -> None:
        self.sources.append(source)

    def poll(self, t_s: float) -> InputFrame:
        return merge_frames(s.poll(t_s) for s in self.sources)

    def statuses(self) -> list[InputStatus]:
        return [s.status() for s in self.sources]

    def blocking(self) -> InputStatus | None:
        """The first source that asks the drive to wait, if any."""
        for st in self.statuses():
            if st.blocking:
                return st
        return None

    def close(self) -> None:
        for s in self.sources:
            try:
                s.close()
            except Exception:  # closing one device must not keep the others open
                import logging

                logging.getLogger(__name__).exception("closing input source %s failed", getattr(s, "name", s))
