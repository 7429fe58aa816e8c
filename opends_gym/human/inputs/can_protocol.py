"""OpenDS's CAN-gateway text protocol: framing, safe parsing and the meaning of each action.

Why: the gateway streams `<message><action name="steering">-92</action></message>` over
TCP (OpenDS `CANClient`; docs/opends-compatibility.md#can). OpenDS wraps each read in `<CAN>...</CAN>` and parses it; a
broken read is silently lost. We keep OpenDS's meaning of every action but frame the
stream on `</message>` (a message split over two reads is put back together), bound
everything (10000 characters, as OpenDS's read buffer), parse with entity expansion and
network access off, and log and skip whatever is malformed, oversized or out of range.

Valid ranges (outside them a value is logged and ignored, never clamped into meaning):
steering |deg| <= 3600 (then clamped to +-maxSteeringAngle), acceleration and brake
0..1, setGear -1..9, channel voltages 0..12 V, display text <= 1000 characters.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field

from lxml import etree

from ..wire import RateLimitedWarning, ascii_float, ascii_int

log = logging.getLogger(__name__)

MAX_MESSAGE_CHARS = 10000
STEERING_DEADBAND = 0.001
MAX_STEERING_DEG = 3600.0
_END = re.compile(r"</message\s*>", re.IGNORECASE)
_START = re.compile(r"<message[\s>/]", re.IGNORECASE)
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, recover=False)


@dataclass
class GatewayUpdate:
    """What one or more gateway actions change; levels None = unchanged."""

    steering: float | None = None
    accelerator: float | None = None
    brake: float | None = None
    gear: int | None = None
    reverse: bool | None = None
    automatic: bool | None = None
    commands: list[str] = field(default_factory=list)  # toggle_cam, reset_car
    messages: list[tuple[str, float]] = field(default_factory=list)


class GatewayFramer:
    """Cuts a byte stream into complete `<message>` chunks (see the module docstring)."""

    def __init__(self, warn: RateLimitedWarning | None = None) -> None:
        self.buffer = ""
        self.dropped = 0
        self.warn = warn if warn is not None else RateLimitedWarning(log)

    def reset(self) -> None:
        self.buffer = ""

    def feed(self, data: bytes | str) -> list[str]:
        text = data.decode("utf-8", errors="replace") if isinstance(data, bytes) else data
        self.buffer += text.replace("\0", "")
        out: list[str] = []
        while True:
            m = _END.search(self.buffer)
            if m is None:
                break
            chunk, self.buffer = self.buffer[: m.end()], self.buffer[m.end() :]
            if len(chunk) > MAX_MESSAGE_CHARS:
                self.dropped += 1
                self.warn.warn("CAN gateway: oversized message of %d characters ignored", len(chunk))
                continue
            out.append(chunk)
        if len(self.buffer) > MAX_MESSAGE_CHARS:
            self.dropped += 1
            self.warn.warn("CAN gateway: %d characters without a complete message ignored", len(self.buffer))
            self.buffer = ""
        return out


def parse_chunk(chunk: str, max_steering_deg: float) -> tuple[GatewayUpdate, list[str]]:
    """Interpret one framed chunk; returns the update and the problems found (for the log)."""
    problems: list[str] = []
    root = _parse(chunk)
    if root is None:
        # resynchronise on the last message start (a half message followed by a whole one)
        starts = [m.start() for m in _START.finditer(chunk) if m.start() > 0]
        root = _parse(chunk[starts[-1] :]) if starts else None
        if root is None:
            return GatewayUpdate(), [f"malformed message ignored: {chunk[:80]!r}"]
        problems.append(f"malformed text before a message ignored: {chunk[: starts[-1]][:80]!r}")
    update = GatewayUpdate()
    for message in root.iter("message"):
        for action in message.iter("action"):
            name = action.get("name", "")
            value = "".join(action.itertext()).strip()
            try:
                _apply(update, name, value, action, max_steering_deg)
            except ValueError as e:
                problems.append(f"action '{name}' = {value[:40]!r}: {e}")
    return update, problems


def _parse(text: str) -> etree._Element | None:
    try:
        return etree.fromstring(("<CAN>" + text + "</CAN>").encode("utf-8"), _PARSER)
    except etree.XMLSyntaxError:
        return None


def _number(value: str, lo: float, hi: float) -> float:
    try:
        v = ascii_float(value)
    except ValueError:
        raise ValueError("not a number (ASCII digits only)") from None
    if not math.isfinite(v) or not lo <= v <= hi:
        raise ValueError(f"out of range [{lo:g}, {hi:g}]")
    return v


def _integer(value: str, lo: int, hi: int) -> int:
    try:
        v = ascii_int(value)
    except ValueError:
        raise ValueError("not an integer (ASCII digits only)") from None
    if not lo <= v <= hi:
        raise ValueError(f"out of range [{lo}, {hi}]")
    return v


def _volt_fraction(v: float, zero: float, full: float) -> float:
    t = (v - zero) / (full - zero)
    return 0.0 if t < 0 else 1.0 if t > 1 else t


def _apply(u: GatewayUpdate, name: str, value: str, action: etree._Element, max_deg: float) -> None:
    if name == "steering":
        deg = _number(value, -MAX_STEERING_DEG, MAX_STEERING_DEG)
        s = -max(-1.0, min(1.0, deg / max_deg))
        u.steering = 0.0 if abs(s) <= STEERING_DEADBAND else s
    elif name == "acceleration":
        u.accelerator = min(_number(value, 0.0, 1.0) * 6.0, 1.0)
    elif name == "brake":
        u.brake = _number(value, 0.0, 1.0)
    elif name in ("MFLplus_State", "MFLtelefoneEnd_State"):
        on = _integer(value, -(2**31), 2**31) != 0
        u.accelerator = 1.0 if on else 0.0
        if on:
            u.reverse = False
    elif name == "MFLminus_State":  # reverse throttle: the runner selects reverse gear
        on = _integer(value, -(2**31), 2**31) != 0
        u.accelerator = 1.0 if on else 0.0
        u.reverse = on
    elif name == "KL54_RM_State":
        u.brake = 1.0 if _integer(value, -(2**31), 2**31) else 0.0
    elif name == "button":
        if value == "cs":
            u.commands.append("toggle_cam")
        elif value == "return":
            u.commands.append("reset_car")
        elif value == "resetPosition":  # ours: the car back on its last lane position
            u.commands.append("reset_position")
        else:
            raise ValueError("unknown button (expected cs, return or resetPosition)")
    elif name == "setGear":
        u.gear = _integer(value, -1, 9)
    elif name == "automaticTransmission":
        if value.lower() not in ("true", "false", "1", "0"):
            raise ValueError("expected true or false")
        u.automatic = value.lower() in ("true", "1")
    elif name == "display":
        if len(value) > 1000:
            raise ValueError("display text longer than 1000 characters")
        try:
            duration = ascii_float(action.get("duration", "0") or "0")
        except ValueError:
            duration = 0.0
        u.messages.append((value, duration if math.isfinite(duration) and duration > 0 else 0.0))
    elif name == "channel0":
        u.steering = -(2.0 * _volt_fraction(_number(value, 0.0, 12.0), 0.0, 5.04) - 1.0)
    elif name == "channel1":
        u.accelerator = _volt_fraction(_number(value, 0.0, 12.0), 0.1, 5.0)
    elif name == "channel2":
        u.brake = _volt_fraction(_number(value, 0.0, 12.0), 1.0, 5.0)
    elif name == "channel3":
        _number(value, 0.0, 12.0)  # read but unused, as in OpenDS
    else:
        raise ValueError("unknown action")
