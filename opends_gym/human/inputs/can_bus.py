"""A real CAN bus (python-can) with signals decoded from a DBC file (cantools).

Why: a cockpit or instrumented car often speaks plain CAN, not OpenDS's XML gateway.
python-can opens any bus (SocketCAN, PCAN, Vector, `virtual` within one process,
`udp_multicast` across processes); cantools decodes the frames by the lab's DBC. The
signal names come from `CanBusMapping` (defaults match the shipped example DBC,
`opends_gym.resources.example_dbc()`, the repository's `configs/can_example.dbc`).
Frames are received on a background thread and queued; `poll` applies them once per
physics step. Feedback frames (speed, rpm, heading, gear; position) are encoded by the
same DBC and sent at the update rate. Unknown ids are ignored; undecodable, non-finite or
out-of-range signals are logged and skipped; a failing bus is reopened with backoff.
"""

from __future__ import annotations

import contextlib
import logging
import math
import queue
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from ...extras import require
from ...resources import example_dbc
from ..wire import RateLimitedWarning
from .base import InputFrame, InputStatus

log = logging.getLogger(__name__)
DEFAULT_DBC = example_dbc()
TURN_SIGNALS = {0: "off", 1: "left", 2: "right", 3: "both"}


@dataclass(frozen=True)
class CanBusMapping:
    """Which DBC signals mean what (empty names are not used)."""

    steering_deg: str = "SteeringWheelAngle"
    accelerator_percent: str = "AcceleratorPedal"
    brake_percent: str = "BrakePedal"
    clutch_percent: str = "ClutchPedal"
    gear: str = "Gear"
    reaction_button: str = "ReactionButton"
    horn: str = "Horn"
    turn_signal: str = "TurnSignal"
    shift_up: str = "ShiftUp"
    shift_down: str = "ShiftDown"
    reset_car: str = "ResetCar"
    reset_position: str = "ResetPosition"
    pause: str = "PauseButton"
    button_number: str = "ButtonNumber"
    feedback_state: str = "SimVehicleState"
    feedback_position: str = "SimVehiclePosition"


class CanBusSource:
    """Drive from CAN frames (see the module docstring)."""

    name = "can-bus"

    def __init__(
        self,
        interface: str,
        channel: str,
        dbc: str | Path = DEFAULT_DBC,
        max_steering_deg: float = 270.0,
        update_rate_hz: float = 20.0,
        mapping: CanBusMapping | None = None,
        bus_kwargs: dict[str, Any] | None = None,
        start: bool = True,
    ) -> None:
        cantools = require("can", "cantools", "the CAN bus input")
        self.db: Any = cast(Any, cantools.database.load_file(str(dbc)))
        self.interface, self.channel = interface, channel
        self.bus_kwargs = dict(bus_kwargs or {})
        self.max_steering_deg = float(max_steering_deg)
        self.update_period_s = 1.0 / update_rate_hz if update_rate_hz > 0 else 0.05
        self.map = mapping or CanBusMapping()
        self._signals = {s.name: s for m in self.db.messages for s in m.signals}
        self._queue: queue.Queue[dict[str, float]] = queue.Queue(1000)
        self._levels: dict[str, float] = {}
        self._stop = threading.Event()
        self._bus: Any = None
        self._lock = threading.Lock()
        self.connected = False
        self.state = "opening"
        self.problems = 0
        self.warn = RateLimitedWarning(log)  # a bus full of bad frames logs one line per 5 s
        self.frames = 0
        self.opened = 0
        self._next_feedback_t = 0.0
        self._thread = threading.Thread(target=self._run, name="can-bus", daemon=True)
        if start:
            self._thread.start()

    # ------------------------------------------------------------------ receive thread
    def _open(self) -> Any:
        can = require("can", "can", "the CAN bus input")

        return can.Bus(interface=self.interface, channel=self.channel, **self.bus_kwargs)

    def _run(self) -> None:
        backoff = 0.25
        while not self._stop.is_set():
            try:
                bus = self._open()
            except Exception as e:
                self.state = f"cannot open {self.interface}:{self.channel} ({e}); retrying in {backoff:.1f} s"
                log.debug("CAN bus: %s", self.state)
                self._stop.wait(backoff)
                backoff = min(5.0, backoff * 2)
                continue
            backoff = 0.25
            with self._lock:
                self._bus = bus
            self.connected = True
            self.opened += 1
            self.state = f"open on {self.interface}:{self.channel}"
            try:
                while not self._stop.is_set():
                    msg = bus.recv(timeout=0.05)
                    if msg is not None:
                        self._receive(int(msg.arbitration_id), bytes(msg.data))
            except Exception as e:
                self.problems += 1
                self.state = f"bus error ({e}); reopening"
                log.warning("CAN bus: %s", self.state)
            finally:
                self.connected = False
                with self._lock:
                    self._bus = None
                with contextlib.suppress(Exception):
                    bus.shutdown()

    def _receive(self, frame_id: int, data: bytes) -> None:
        try:
            message = self.db.get_message_by_frame_id(frame_id)
        except KeyError:
            return  # other traffic on the bus
        try:
            values = message.decode(data, decode_choices=False)
        except Exception as e:
            self.problems += 1
            self.warn.warn("CAN bus: frame 0x%X (%s) cannot be decoded: %s", frame_id, message.name, e)
            return
        good: dict[str, float] = {}
        for name, v in values.items():  # type: ignore[union-attr]
            sig = self._signals.get(name)
            try:
                fv = float(v)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                continue
            lo = sig.minimum if sig is not None and sig.minimum is not None else -math.inf
            hi = sig.maximum if sig is not None and sig.maximum is not None else math.inf
            if not math.isfinite(fv) or not lo <= fv <= hi:
                self.problems += 1
                self.warn.warn("CAN bus: %s = %r is out of range [%s, %s]; ignored", name, v, lo, hi)
                continue
            good[name] = fv
        try:
            self._queue.put_nowait(good)
        except queue.Full:
            self.problems += 1
        self.frames += 1  # (after the queue: a frame counted is one the next poll applies)

    # ------------------------------------------------------------------ simulation side
    def poll(self, t_s: float) -> InputFrame:
        m = self.map
        f = InputFrame()
        prev = dict(self._levels)
        buttons: list[int] = []
        commands: list[str] = []
        while True:
            try:
                values = self._queue.get_nowait()
            except queue.Empty:
                break
            for name, v in values.items():
                old = self._levels.get(name, 0.0)
                self._levels[name] = v
                if v and not old:  # rising edges of buttons
                    if name == m.reaction_button:
                        buttons.append(0)
                    elif name == m.button_number:
                        buttons.append(int(v) - 1)
                    elif name == m.shift_up:
                        f.shift_up = True
                    elif name == m.shift_down:
                        f.shift_down = True
                    elif name == m.reset_car:
                        commands.append("reset_car")
                    elif name == m.reset_position:
                        commands.append("reset_position")
                    elif name == m.pause:
                        commands.append("toggle_pause")
        lv = self._levels
        if m.steering_deg in lv:
            s = -max(-1.0, min(1.0, lv[m.steering_deg] / self.max_steering_deg))
            f.steering = 0.0 if abs(s) <= 0.001 else s
        for attr, sig in (("accelerator", m.accelerator_percent), ("brake", m.brake_percent), ("clutch", m.clutch_percent)):
            if sig in lv:
                setattr(f, attr, max(0.0, min(1.0, lv[sig] / 100.0)))
        if m.horn in lv:
            f.horn = bool(lv[m.horn])
        if m.turn_signal in lv and lv.get(m.turn_signal) != prev.get(m.turn_signal):
            f.turn_signal = TURN_SIGNALS.get(int(lv[m.turn_signal]), "off")
        if m.gear in lv and lv.get(m.gear) != prev.get(m.gear) and int(lv[m.gear]) != 0:
            f.gear = int(lv[m.gear])  # 0 = no request: the gearbox (automatic) decides
        f.buttons = tuple(buttons)
        f.keys = tuple(f"JOY_{b}" for b in buttons)
        f.commands = tuple(commands)
        return f

    def feedback(self, snapshot: Any) -> None:
        """Encode and send the feedback frames at the update rate (simulation time)."""
        t = float(snapshot.t_s)
        if t + 1e-9 < self._next_feedback_t:
            return
        self._next_feedback_t = t + self.update_period_s
        with self._lock:
            bus = self._bus
        if bus is None:
            return
        import can

        frames = []
        try:
            if self.map.feedback_state:
                msg = self.db.get_message_by_name(self.map.feedback_state)
                data = msg.encode(
                    {
                        "VehicleSpeed": min(655.35, abs(snapshot.speed_kmh)),
                        "EngineRpm": min(65535.0, max(0.0, snapshot.rpm)),
                        "Heading": snapshot.heading_deg % 360.0,
                        "CurrentGear": max(-1, min(6, int(snapshot.gear))),
                    }
                )
                frames.append(can.Message(arbitration_id=msg.frame_id, data=data, is_extended_id=msg.is_extended_frame))
            if self.map.feedback_position:
                msg = self.db.get_message_by_name(self.map.feedback_position)
                data = msg.encode({"PositionX": snapshot.x_m, "PositionZ": snapshot.z_m})
                frames.append(can.Message(arbitration_id=msg.frame_id, data=data, is_extended_id=msg.is_extended_frame))
            for fr in frames:
                bus.send(fr, timeout=0.01)
        except Exception as e:  # a full TX queue or a value the DBC cannot hold
            self.problems += 1
            self.warn.warn("CAN bus: feedback not sent: %s", e)

    def status(self) -> InputStatus:
        """Until the bus has opened once, the drive waits (blocking); later failures are shown."""
        if self.connected:
            return InputStatus(self.name)
        return InputStatus(self.name, connected=False, message=f"CAN bus: {self.state}", blocking=self.opened == 0)

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(1.0)
