"""OpenDS's CAN gateway over TCP as an input source, with the feedback channel.

Why: labs with an instrumented car or a cockpit run a "CAN gateway" that turns the
car's CAN bus into OpenDS's XML text protocol. OpenDS is the TCP *client*
(`CANInterface ip:port`, default 192.168.0.2:5678). The connection lives on a background
thread (`ReconnectingClient`): reads are framed and parsed there (`can_protocol`), and
the resulting updates are queued; `poll` applies them once per physics step, so the
simulation sees them in a fixed order. A dropped gateway is retried with backoff and
shown in the status; nothing it sends can end the session.

Feedback: OpenDS 4.5 has `$SimCarState#speed#heading#lat#lon%` commented out; we send it
at `updateRate` (simulation time), with the model x and z in the lat/lon slots (tasks
carry no geo-reference), and `exit` when the session ends.
"""

from __future__ import annotations

import logging
import math
import queue
from typing import Any

from ..net import ReconnectingClient
from ..wire import RateLimitedWarning
from .base import InputFrame, InputStatus
from .can_protocol import GatewayFramer, GatewayUpdate, parse_chunk

log = logging.getLogger(__name__)
MAX_PENDING = 1000


class CanGatewaySource:
    """TCP client of a CAN gateway (see the module docstring)."""

    name = "can-gateway"

    def __init__(self, host: str, port: int, max_steering_deg: float = 270.0, update_rate_hz: float = 20.0, start: bool = True) -> None:
        if not (math.isfinite(max_steering_deg) and max_steering_deg > 0):
            raise ValueError(f"maxSteeringAngle must be positive, not {max_steering_deg}")
        self.max_steering_deg = float(max_steering_deg)
        self.update_period_s = 1.0 / update_rate_hz if update_rate_hz and update_rate_hz > 0 else 0.05
        self.warn = RateLimitedWarning(log)  # one per source: a flooding gateway logs one line per 5 s
        self.framer = GatewayFramer(self.warn)
        self.problems = 0
        self.messages_received = 0  # messages the I/O thread parsed (counted once queued, or dropped on a full queue)
        self.messages_applied = 0
        self._updates: queue.Queue[GatewayUpdate] = queue.Queue(MAX_PENDING)
        self._levels = InputFrame()
        self._next_feedback_t = 0.0
        self.client = ReconnectingClient(
            host, port, on_data=self._on_data, on_connect=self.framer.reset, name="CAN gateway", goodbye=b"exit"
        )
        if start:
            self.client.start()

    @classmethod
    def from_settings(cls, settings: Any, host: str | None = None, port: int | None = None) -> CanGatewaySource:
        can = settings.can_interface
        return cls(
            host or can.ip,
            int(port or can.port),
            max_steering_deg=math.degrees(can.max_steering_angle_rad),
            update_rate_hz=float(can.update_rate_hz),
        )

    # ------------------------------------------------------------------ I/O thread
    def _on_data(self, data: bytes) -> None:
        dropped = self.framer.dropped
        chunks = self.framer.feed(data)
        self.problems += self.framer.dropped - dropped  # oversized or unterminated input
        for chunk in chunks:
            update, problems = parse_chunk(chunk, self.max_steering_deg)
            for p in problems:
                self.problems += 1
                self.warn.warn("CAN gateway: %s", p)
            try:
                self._updates.put_nowait(update)
            except queue.Full:
                self.problems += 1
                self.warn.warn("CAN gateway: the simulation is not keeping up; a message was dropped")
            self.messages_received += 1

    # ------------------------------------------------------------------ simulation side
    def poll(self, t_s: float) -> InputFrame:
        f = InputFrame()
        commands: list[str] = []
        messages: list[tuple[str, float]] = []
        lv = self._levels
        while True:
            try:
                u = self._updates.get_nowait()
            except queue.Empty:
                break
            self.messages_applied += 1
            for name in ("steering", "accelerator", "brake", "reverse"):
                v = getattr(u, name)
                if v is not None:
                    setattr(lv, name, v)
            if u.gear is not None:
                f.gear = u.gear
            if u.automatic is not None:
                f.automatic = u.automatic
            commands.extend(u.commands)
            messages.extend(u.messages)
        f.steering, f.accelerator, f.brake, f.reverse = lv.steering, lv.accelerator, lv.brake, lv.reverse
        f.commands = tuple(commands)
        f.messages = tuple(messages)
        return f

    def feedback(self, snapshot: Any) -> bool:
        """Send `$SimCarState#speed#heading#x#z%` at the gateway's update rate; True when sent now."""
        t = float(snapshot.t_s)
        if t + 1e-9 < self._next_feedback_t or not self.client.connected:
            return False
        self._next_feedback_t = t + self.update_period_s
        return self.client.send(f"$SimCarState#{snapshot.speed_kmh:.2f}#{snapshot.heading_deg:.2f}#{snapshot.x_m:.3f}#{snapshot.z_m:.3f}%")

    def status(self) -> InputStatus:
        """Until the gateway has connected once, the drive waits (blocking); later losses are shown."""
        c = self.client
        if c.connected:
            return InputStatus(self.name)
        waiting = c.connections == 0
        return InputStatus(self.name, connected=False, message=f"CAN gateway: {c.state}", blocking=waiting)

    def close(self) -> None:
        self.client.close()
