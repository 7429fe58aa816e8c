"""`HudOverlay`: the driver's instruments and the trigger core's screen output.

Why: the human viewer and `render_mode="human"` show what OpenDS shows on top of the
scene: analog dials (speed 0-260 km/h and rpm 0-7500 as OpenDS's gauges: zero at 192
degrees, 1 km/h or 50 rpm per degree) and/or digital read-outs per settings
(`showAnalogIndicators` default on, `showDigitalIndicators` and `showFuelConsumption`
default off, as in OpenDS), the gear, fuel, the `sendMessage` text, pictures toggled by
`manipulatePicture` (a labelled placeholder when the image file is missing), the
instruction screen, a pause indicator, the flashing warning frame, `setOpenDSGauge`
indicators and a short feedback line after each scored reaction. Everything is read from
the World at its current simulation time, so it replays identically.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Any

from . import _pg
from . import palette as pal

FEEDBACK_S = 2.0
SPEED_MAX_KMH, RPM_MAX = 260.0, 7500.0


def needle_angle_rad(value: float, per_degree: float, maximum: float) -> float:
    """OpenDS gauge geometry: zero at 192 degrees (counter-clockwise from +x), `per_degree` units per degree."""
    v = min(max(value, 0.0), maximum)
    return math.radians(192.0 - v / per_degree)


@lru_cache(maxsize=8)
def _dial_face(radius: int, kind: str) -> Any:
    """A cached dial face (circle, ticks, numbers) for 'speed' or 'rpm'."""
    pg = _pg.pygame()
    size = 2 * radius + 2
    face = pg.Surface((size, size), pg.SRCALPHA)
    c = (radius + 1, radius + 1)
    pg.draw.circle(face, (*pal.HUD_BG, 255), c, radius)
    pg.draw.circle(face, (170, 170, 170, 255), c, radius, max(1, radius // 30))
    if kind == "speed":
        marks, per_deg, maximum, major, label = range(0, 261, 10), 1.0, SPEED_MAX_KMH, 20, "km/h"
    else:
        marks, per_deg, maximum, major, label = range(0, 7501, 500), 50.0, RPM_MAX, 1000, "x1000 rpm"
    fsize = max(8, radius // 6)
    for v in marks:
        a = needle_angle_rad(v, per_deg, maximum)
        big = v % major == 0
        r0 = radius * (0.78 if big else 0.86)
        p0 = (c[0] + r0 * math.cos(a), c[1] - r0 * math.sin(a))
        p1 = (c[0] + 0.95 * radius * math.cos(a), c[1] - 0.95 * radius * math.sin(a))
        pg.draw.line(face, pal.HUD_TEXT, p0, p1, 2 if big else 1)
        if big and (kind == "rpm" or v % 40 == 0):
            txt = str(v if kind == "speed" else v // 1000)
            _pg.text(face, txt, (c[0] + 0.62 * radius * math.cos(a), c[1] - 0.62 * radius * math.sin(a)), fsize, pal.HUD_TEXT, "center")
    _pg.text(face, label, (c[0], c[1] + 0.45 * radius), fsize, (180, 180, 180), "center")
    return face


def _picture_rect(pic: Any, w: int, h: int, size: tuple[int, int]) -> tuple[int, int, int, int]:
    """Screen rectangle of a scene picture from its vPosition/hPosition anchors (px or percent)."""
    pw, ph = size

    def offset(anchor: Any, extent: int) -> float:
        return anchor.value * extent / 100.0 if anchor.unit == "percent" else float(anchor.value)

    v, hp = pic.v_position, pic.h_position
    y = {"fromTop": offset(v, h), "fromBottom": h - offset(v, h) - ph}.get(v.edge, 0.5 * (h - ph))
    x = {"fromLeft": offset(hp, w), "fromRight": w - offset(hp, w) - pw}.get(hp.edge, 0.5 * (w - pw))
    return int(x), int(y), pw, ph


class HudOverlay:
    """Draws the HUD of a World onto a pygame surface (`draw`)."""

    def __init__(
        self,
        world: Any,
        show_analog: bool | None = None,
        show_digital: bool | None = None,
        show_fuel: bool | None = None,
        number_of_screens: int | None = None,
    ) -> None:
        self.world = world
        g = world.task.settings.general
        self.show_analog = (
            (g.show_analog_indicators if g.show_analog_indicators is not None else True) if show_analog is None else show_analog
        )
        self.show_digital = bool(g.show_digital_indicators) if show_digital is None else show_digital
        self.show_fuel = bool(g.show_fuel_consumption) if show_fuel is None else show_fuel
        self.analog = g.analog_indicators
        self.screens = max(1, int(number_of_screens or g.number_of_screens or 1))
        self._images: dict[str, Any] = {}

    # ------------------------------------------------------------------ parts
    def draw(self, surface: Any) -> None:
        """Instruments, pictures, message, reaction feedback, pause, instruction screen, warning frame."""
        w = self.world
        hud = w.triggers.hud
        if self.show_analog:
            self.draw_dials(surface)
        if self.show_digital or self.show_fuel:
            self.draw_digital(surface)
        self.draw_gauges(surface, hud.gauge)
        self.draw_pictures(surface, hud.pictures)
        self.draw_message(surface, hud.message_at(w.t_s))
        self.draw_feedback(surface)
        if w.triggers.paused and hud.instruction_screen is None:
            self.draw_banner(surface, "PAUSED", (250, 220, 80))
        if hud.instruction_screen is not None:
            self.draw_instructions(surface, hud.instruction_screen)
        if hud.warning_frame_on(w.t_s):
            sw, sh = surface.get_size()
            _pg.pygame().draw.rect(surface, pal.WARNING, (0, 0, sw, sh), max(4, min(sw, sh) // 40))

    def _right_edge(self, width: int) -> int:
        """OpenDS moves the gauges toward the centre when there are several screens."""
        return width if self.screens == 1 else int(width * 1.85 / 3.0)

    def draw_dials(self, surface: Any) -> None:
        pg = _pg.pygame()
        sw, sh = surface.get_size()
        a = self.analog
        scale = a.scale if a is not None and a.scale else 1.0
        r = max(12, int(0.075 * min(sw, 1.6 * sh) * scale))
        block_w = 4 * r + 30
        left = self._right_edge(sw) - block_w
        bottom = 10
        if a is not None:
            left = a.left_px if a.left_px is not None else (sw - a.right_px - block_w if a.right_px is not None else left)
            bottom = a.bottom_px if a.bottom_px is not None else (sh - a.top_px - 2 * r if a.top_px is not None else bottom)
        cy = sh - bottom - r
        pt = self.world.ego.powertrain.state
        speed = abs(self.world.ego.state.u) * 3.6
        for cx, kind, value, per, mx in (
            (left + r + 5, "rpm", pt.rpm, 50.0, RPM_MAX),
            (left + 3 * r + 20, "speed", speed, 1.0, SPEED_MAX_KMH),
        ):
            surface.blit(_dial_face(r, kind), (cx - r - 1, cy - r - 1))
            ang = needle_angle_rad(value, per, mx)
            pg.draw.line(surface, (255, 80, 40), (cx, cy), (cx + 0.8 * r * math.cos(ang), cy - 0.8 * r * math.sin(ang)), max(2, r // 25))
            pg.draw.circle(surface, (200, 200, 200), (cx, cy), max(2, r // 12))
        fsize = max(10, r // 4)
        x = left + r + 5
        for letter in ("R", "N", "M", "D"):
            on = self._gear_letter() == letter
            rect = _pg.text(surface, letter, (x - 0.6 * r, cy + 0.62 * r), fsize, (80, 230, 80) if on else (130, 130, 130), "midleft")
            x += rect.width + 3
        _pg.text(surface, self._gear_text(), (left + r + 5, cy + 0.35 * r), fsize, (80, 230, 80), "center")
        _pg.text(surface, f"fuel {pt.fuel_left_l:.1f} l", (left + 3 * r + 20, cy + 0.68 * r), fsize, (190, 190, 190), "center")

    def _gear_letter(self) -> str:
        pt = self.world.ego.powertrain.state
        if pt.gear < 0:
            return "R"
        if pt.gear == 0:
            return "N"
        return "D" if pt.automatic else "M"

    def _gear_text(self) -> str:
        pt = self.world.ego.powertrain.state
        return {-1: "R", 0: "N"}.get(pt.gear, str(pt.gear))

    def draw_digital(self, surface: Any) -> None:
        sw, sh = surface.get_size()
        right = self._right_edge(sw)
        size = max(12, sh // 30)
        y = sh - 8
        pt = self.world.ego.powertrain.state
        if self.show_digital:
            _pg.text(
                surface, f"{abs(self.world.ego.state.u) * 3.6:.0f} km/h", (right - 90 * size / 24, y), size, pal.HUD_TEXT, "bottomleft"
            )
            _pg.text(surface, f"{pt.rpm:.0f} rpm", (right / 4, y), size, pal.HUD_TEXT, "bottomleft")
            _pg.text(
                surface,
                f"gear {self._gear_letter()}{'' if pt.gear <= 0 else ' ' + str(pt.gear)}",
                (right / 2, y),
                size,
                pal.HUD_TEXT,
                "bottomleft",
            )
            odo = pt.odometer_m
            _pg.text(surface, f"{odo:.0f} m" if odo < 1000 else f"{odo / 1000:.2f} km", (8, y), size, pal.HUD_TEXT, "bottomleft")
        if self.show_fuel:
            y2 = y - size - 4
            _pg.text(surface, f"{pt.l_per_100km:.1f} l/100km", (right / 2, y2), size, pal.HUD_TEXT, "bottomleft")
            _pg.text(surface, f"{pt.l_per_h:.1f} l/h", (right / 4, y2), size, pal.HUD_TEXT, "bottomleft")
            _pg.text(surface, f"fuel {pt.fuel_left_l:.1f} l (used {pt.fuel_used_l:.2f} l)", (8, y2), size, pal.HUD_TEXT, "bottomleft")

    def draw_gauges(self, surface: Any, gauge: dict[str, str]) -> None:
        pg = _pg.pygame()
        sw, sh = surface.get_size()
        limit = gauge.get("speed_limit_indicator", "")
        if limit and limit not in ("0", "-1", "off"):
            r = max(10, sh // 16)
            c = (sw - r - 12, r + 12)
            pg.draw.circle(surface, (255, 255, 255), c, r)
            pg.draw.circle(surface, (210, 20, 20), c, r, max(3, r // 5))
            _pg.text(surface, limit, c, int(r * 0.9), (0, 0, 0), "center")
        ap = gauge.get("auto_pilot_indicator", "")
        if ap:
            _pg.text(surface, f"AUTOPILOT {ap.upper()}", (12, 12), max(12, sh // 32), (120, 200, 255), "topleft")

    def draw_pictures(self, surface: Any, shown: dict[str, bool]) -> None:
        if not any(shown.values()):
            return
        sw, sh = surface.get_size()
        for pic in sorted(self.world.task.scene.pictures, key=lambda p: p.level):
            if not shown.get(pic.id):
                continue
            img = self._image(pic.key)
            size = (
                pic.width_px or (img.get_width() if img is not None else 200),
                pic.height_px or (img.get_height() if img is not None else 120),
            )
            x, y, pw, ph = _picture_rect(pic, sw, sh, size)
            if img is not None:
                pg = _pg.pygame()
                surface.blit(pg.transform.smoothscale(img, (pw, ph)) if img.get_size() != (pw, ph) else img, (x, y))
            else:
                pg = _pg.pygame()
                pg.draw.rect(surface, (60, 60, 70), (x, y, pw, ph))
                pg.draw.rect(surface, (230, 230, 230), (x, y, pw, ph), 2)
                _pg.text(surface, pic.id, (x + pw / 2, y + ph / 2), max(10, min(ph // 4, 28)), pal.HUD_TEXT, "center")

    def _image(self, key: str) -> Any:
        """The picture file beside the task (loaded once), or None when it is missing or unreadable."""
        if key not in self._images:
            img = None
            path = Path(self.world.task.folder) / key if key else None
            if path is not None and path.is_file():
                try:
                    img = _pg.pygame().image.load(str(path))
                except Exception:  # unreadable image: fall back to the placeholder, never crash the session
                    img = None
            self._images[key] = img
        return self._images[key]

    def _panel(self, surface: Any, lines: list[tuple[str, tuple[int, int, int]]], centre_y: float, size: int, alpha: int = 190) -> None:
        pg = _pg.pygame()
        sw, _ = surface.get_size()
        imgs = [_pg.font(size).render(s, True, col) for s, col in lines]
        bw = min(sw - 8, max(i.get_width() for i in imgs) + 2 * size)
        bh = sum(i.get_height() for i in imgs) + size
        box = pg.Surface((bw, bh), pg.SRCALPHA)
        box.fill((*pal.HUD_BG, alpha))
        top = int(centre_y - bh / 2)
        surface.blit(box, (int((sw - bw) / 2), top))
        y = top + size // 2
        for img in imgs:
            surface.blit(img, img.get_rect(midtop=(sw // 2, y)))
            y += img.get_height()

    def draw_message(self, surface: Any, message: str) -> None:
        if message:
            sh = surface.get_size()[1]
            self._panel(surface, [(line, pal.HUD_TEXT) for line in message.splitlines() or [message]], 0.16 * sh, max(12, sh // 22))

    def draw_feedback(self, surface: Any) -> None:
        reactions = getattr(self.world.triggers, "reactions", ())
        if not reactions:
            return
        r = reactions[-1]
        if not 0.0 <= self.world.t_s - r.t_s < FEEDBACK_S:
            return
        text, col = {1: (f"CORRECT  {r.reaction_time_s:.2f} s", (80, 230, 80)), -1: ("FAILED", (240, 70, 60))}.get(
            r.result, ("MISSED", (250, 170, 40))
        )
        sh = surface.get_size()[1]
        self._panel(surface, [(text, col)], 0.3 * sh, max(12, sh // 24))

    def draw_banner(self, surface: Any, text: str, color: tuple[int, int, int]) -> None:
        sh = surface.get_size()[1]
        self._panel(surface, [(text, color)], 0.5 * sh, max(14, sh // 14))

    def draw_instructions(self, surface: Any, instruction_id: str) -> None:
        pg = _pg.pygame()
        sw, sh = surface.get_size()
        dim = pg.Surface((sw, sh), pg.SRCALPHA)
        dim.fill((0, 0, 0, 170))
        surface.blit(dim, (0, 0))
        self._panel(
            surface,
            [(f"Instructions: {instruction_id}", pal.HUD_TEXT), ("Press Return or Space to continue", (200, 200, 200))],
            0.5 * sh,
            max(14, sh // 20),
            230,
        )


class WithHud:
    """A renderer whose frames carry the HUD (what `render_mode="human"` shows)."""

    def __init__(self, renderer: Any, world: Any) -> None:
        self.renderer = renderer
        self.hud = HudOverlay(world)

    def render(self, width: int, height: int) -> Any:
        return _pg.to_array(self.render_surface(width, height))

    def render_surface(self, width: int, height: int) -> Any:
        surface = self.renderer.render_surface(width, height)
        self.hud.draw(surface)
        return surface
