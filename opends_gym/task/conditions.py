"""Trigger conditions in both forms: `type:arg[:arg]` strings and 2023 structured children.

Why: every OpenDS version writes `<condition>collideWith:box</condition>`; the 2023 schema
adds `<condition><pressKey><key>KEY_A</key></pressKey></condition>`. Both load into the
same small dataclasses, and an unknown type is kept (and warned about) rather than lost.
"""

from __future__ import annotations

from dataclasses import dataclass

from lxml import etree

from .bind import FLOAT, INT, ReadCtx, WriteCtx, children, parse_scalar
from .xmlsafe import local_name

PEDALS = ("combinedPedals", "accelerator", "brake", "clutch")
DEFAULT_PEDAL_THRESHOLD = 0.2


def canonical_key(name: str) -> str:
    """jME key names with the optional `KEY_` prefix made explicit: `a` -> `KEY_A`."""
    n = name.strip().upper()
    if n.startswith("JOY_") or n.startswith("BUTTON_"):
        return n
    return n if n.startswith("KEY_") else "KEY_" + n


@dataclass(frozen=True)
class CollideWith:
    model_id: str


@dataclass(frozen=True)
class PressKey:
    key: str  # canonical jME name, e.g. KEY_A


@dataclass(frozen=True)
class PressButton:
    button: int
    device_id: int = 0


@dataclass(frozen=True)
class PressPedal:
    pedal: str
    threshold: float = DEFAULT_PEDAL_THRESHOLD


@dataclass(frozen=True)
class Remote:
    trigger_id: str


@dataclass(frozen=True)
class CameraWaypoint:
    waypoint_id: str


@dataclass(frozen=True)
class OpenDrivePos:
    """Fires when the car (or a traffic car) is within 0.5 m of `s` on that road and lane."""

    road_id: str
    s_m: float
    lane: int = 0  # 0 = any lane
    traffic_car_id: str | None = None


@dataclass(frozen=True)
class UnknownCondition:
    """A condition type OpenDS would reject; kept so the file saves back unchanged."""

    text: str


Condition = CollideWith | PressKey | PressButton | PressPedal | Remote | CameraWaypoint | OpenDrivePos | UnknownCondition


@dataclass(frozen=True)
class ConditionSet:
    """All conditions of one trigger (any of them fires it) and the form they were written in."""

    items: tuple[Condition, ...] = ()
    structured: bool = False


def parse_condition_string(text: str, el: etree._Element, ctx: ReadCtx) -> Condition:
    parts = [p.strip() for p in text.strip().split(":")]
    kind, args = parts[0], parts[1:]

    def need(n: int) -> None:
        if len(args) < n or not all(args[:n]):
            raise ctx.error(f"condition '{text.strip()}' needs {n} argument(s) after '{kind}:'", el, "condition")

    if kind == "collideWith":
        need(1)
        return CollideWith(":".join(args))
    if kind == "pressKey":
        need(1)
        return PressKey(canonical_key(args[0]))
    if kind == "pressButton":
        need(1)
        return PressButton(parse_scalar(INT, args[0], el, ctx, "condition pressButton"))
    if kind == "pressPedal":
        need(1)
        if args[0] not in PEDALS:
            raise ctx.error(f"unknown pedal '{args[0]}' (one of {', '.join(PEDALS)})", el, "condition")
        threshold = (
            parse_scalar(FLOAT, args[1], el, ctx, "condition pressPedal threshold")
            if len(args) > 1 and args[1]
            else DEFAULT_PEDAL_THRESHOLD
        )
        return PressPedal(args[0], threshold)
    if kind == "remote":
        need(1)
        return Remote(":".join(args))
    if kind == "cameraWaypoint":
        need(1)
        return CameraWaypoint(":".join(args))
    ctx.warn(f"unknown condition type '{kind}'; the trigger will never fire", el, "condition", once_key=f"cond:{kind}")
    return UnknownCondition(text.strip())


def format_condition_string(c: Condition) -> str:
    if isinstance(c, CollideWith):
        return f"collideWith:{c.model_id}"
    if isinstance(c, PressKey):
        return f"pressKey:{c.key}"
    if isinstance(c, PressButton):
        return f"pressButton:{c.button}"
    if isinstance(c, PressPedal):
        return f"pressPedal:{c.pedal}:{c.threshold!r}"
    if isinstance(c, Remote):
        return f"remote:{c.trigger_id}"
    if isinstance(c, CameraWaypoint):
        return f"cameraWaypoint:{c.waypoint_id}"
    if isinstance(c, UnknownCondition):
        return c.text
    raise ValueError(f"{type(c).__name__} has no string form")


def _text(el: etree._Element, tag: str, ctx: ReadCtx, required: bool = True) -> str | None:
    found = children(el, tag)
    if not found or not (found[0].text or "").strip():
        if required:
            raise ctx.error(f"missing required element <{tag}>", el)
        return None
    return (found[0].text or "").strip()


def _parse_structured(c: etree._Element, ctx: ReadCtx) -> Condition:
    kind = local_name(c)
    if kind == "pressKey":
        return PressKey(canonical_key(_text(c, "key", ctx) or ""))
    if kind == "pressButton":
        dev = _text(c, "deviceID", ctx, False)
        return PressButton(
            parse_scalar(INT, _text(c, "button", ctx) or "", c, ctx, "button"),
            parse_scalar(INT, dev, c, ctx, "deviceID") if dev else 0,
        )
    if kind == "pressPedal":
        pedal = _text(c, "pedal", ctx) or ""
        if pedal not in PEDALS:
            raise ctx.error(f"unknown pedal '{pedal}' (one of {', '.join(PEDALS)})", c)
        th = _text(c, "triggeringThreshold", ctx, False)
        return PressPedal(pedal, parse_scalar(FLOAT, th, c, ctx, "triggeringThreshold") if th else DEFAULT_PEDAL_THRESHOLD)
    if kind == "collideWith":
        return CollideWith(_text(c, "modelID", ctx) or "")
    if kind == "openDrivePos":
        lane = _text(c, "lane", ctx, False)
        return OpenDrivePos(
            road_id=_text(c, "roadID", ctx) or "",
            s_m=parse_scalar(FLOAT, _text(c, "s", ctx) or "", c, ctx, "s"),
            lane=parse_scalar(INT, lane, c, ctx, "lane") if lane else 0,
            traffic_car_id=_text(c, "trafficCarID", ctx, False),
        )
    if kind == "remote":
        return Remote(_text(c, "triggerID", ctx) or "")
    if kind == "cameraWaypoint":
        return CameraWaypoint(_text(c, "waypointID", ctx) or "")
    ctx.warn(f"unknown condition type <{kind}>; it will never fire", c, once_key=f"cond:{kind}")
    return UnknownCondition(kind)


def read_conditions(el: etree._Element, ctx: ReadCtx) -> ConditionSet:
    kids = children(el)
    if kids:
        return ConditionSet(tuple(_parse_structured(c, ctx) for c in kids), structured=True)
    text = (el.text or "").strip()
    if not text:
        raise ctx.error("empty <condition>", el)
    return ConditionSet((parse_condition_string(text, el, ctx),), structured=False)


def write_conditions(el: etree._Element, value: ConditionSet, ctx: WriteCtx) -> None:
    if not value.structured:
        el.text = format_condition_string(value.items[0])
        return
    for c in value.items:
        if isinstance(c, PressKey):
            ctx.sub(ctx.sub(el, "pressKey"), "key").text = c.key
        elif isinstance(c, PressButton):
            n = ctx.sub(el, "pressButton")
            ctx.sub(n, "deviceID").text = str(c.device_id)
            ctx.sub(n, "button").text = str(c.button)
        elif isinstance(c, PressPedal):
            n = ctx.sub(el, "pressPedal")
            ctx.sub(n, "pedal").text = c.pedal
            ctx.sub(n, "triggeringThreshold").text = repr(c.threshold)
        elif isinstance(c, CollideWith):
            ctx.sub(ctx.sub(el, "collideWith"), "modelID").text = c.model_id
        elif isinstance(c, OpenDrivePos):
            n = ctx.sub(el, "openDrivePos")
            if c.traffic_car_id is not None:
                ctx.sub(n, "trafficCarID").text = c.traffic_car_id
            ctx.sub(n, "roadID").text = c.road_id
            ctx.sub(n, "lane").text = str(c.lane)
            ctx.sub(n, "s").text = repr(c.s_m)
        elif isinstance(c, Remote):
            ctx.sub(ctx.sub(el, "remote"), "triggerID").text = c.trigger_id
        elif isinstance(c, CameraWaypoint):
            ctx.sub(ctx.sub(el, "cameraWaypoint"), "waypointID").text = c.waypoint_id
        elif isinstance(c, UnknownCondition):
            ctx.sub(el, c.text)
