"""Weather on screen: fog as a distance blend, rain and snow as deterministic particles.

Why: `setWeather` changes `world.triggers.weather` (snowing_percent, raining_percent,
fog_percent; -1 = off) at run time and the driver must see it. OpenDS uses jME's fog and
particle filters; we keep their meaning, not their pixels:

* fog: percentage p maps log-linearly to a visibility V from 2000 m (p = 0) to 40 m
  (p = 100); colours blend to the fog colour by 1 - exp(-3 d / V) (Koschmieder: 5 %
  contrast left at the visibility distance). Distant things converge to the fog colour.
* rain / snow: p % of `MAX_PARTICLES` (per 1280x720, scaled by area) streaks or flakes
  whose positions depend only on a fixed seed and the simulation time, so the same world
  state renders the same frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import palette as pal

VIS_CLEAR_M, VIS_DENSE_M = 2000.0, 40.0


@dataclass
class Fog:
    """Fog as a colour and an extinction per metre: `amount(d)` = 1 - exp(-density d)."""

    color: tuple[int, int, int]
    density_per_m: float

    def amount(self, depth: np.ndarray) -> np.ndarray:
        return 1.0 - np.exp(-self.density_per_m * np.maximum(depth, 0.0))


MAX_PARTICLES = 900
REF_AREA_PX = 1280 * 720
PARTICLE_SEED = 20240611


def weather_of(world: Any) -> dict[str, float]:
    w = getattr(getattr(world, "triggers", None), "weather", None) or {}
    return {k: float(w.get(k, -1.0)) for k in ("snowing_percent", "raining_percent", "fog_percent")}


def visibility_m(fog_percent: float) -> float:
    p = min(100.0, max(0.0, fog_percent))
    return VIS_DENSE_M * (VIS_CLEAR_M / VIS_DENSE_M) ** (1.0 - p / 100.0)


def fog_for(weather: dict[str, float]) -> Fog | None:
    p = weather.get("fog_percent", -1.0)
    if p is None or p <= 0.0 or math.isnan(p):
        return None
    return Fog(pal.FOG, 3.0 / visibility_m(p))


class Precipitation:
    """Rain streaks and snow flakes in screen space, from a fixed seed and the simulation time."""

    def __init__(self) -> None:
        rng = np.random.default_rng(PARTICLE_SEED)
        self.base = rng.random((MAX_PARTICLES, 2))
        self.speed = 0.6 + 0.8 * rng.random(MAX_PARTICLES)  # screen heights per second
        self.phase = rng.random(MAX_PARTICLES) * 2.0 * math.pi

    def count(self, percent: float, width: int, height: int) -> int:
        if percent is None or percent <= 0.0 or math.isnan(percent):
            return 0
        n = min(100.0, percent) / 100.0 * MAX_PARTICLES * (width * height) / REF_AREA_PX
        return min(MAX_PARTICLES, max(1, int(round(n))))

    def draw(self, surface: Any, weather: dict[str, float], t_s: float) -> None:
        from ._pg import pygame

        pg = pygame()
        w, h = surface.get_size()
        n_rain = self.count(weather.get("raining_percent", -1.0), w, h)
        if n_rain:
            y = (self.base[:n_rain, 1] + 1.6 * self.speed[:n_rain] * t_s) % 1.0 * h
            x = (self.base[:n_rain, 0] * w - 0.05 * y) % w
            length = max(2.0, 0.035 * h)
            for x0, y0 in zip(x.tolist(), y.tolist()):
                pg.draw.line(surface, pal.RAIN, (x0, y0), (x0 - 0.15 * length, y0 + length), 1)
        n_snow = self.count(weather.get("snowing_percent", -1.0), w, h)
        if n_snow:
            sl = slice(MAX_PARTICLES - n_snow, MAX_PARTICLES)  # other particles than the rain's
            y = (self.base[sl, 1] + 0.12 * self.speed[sl] * t_s) % 1.0 * h
            x = (self.base[sl, 0] * w + 0.02 * w * np.sin(self.phase[sl] + 1.3 * t_s)) % w
            size = max(1, int(round(h / 240)))
            fill = surface.fill
            for x0, y0 in zip(x.astype(int).tolist(), y.astype(int).tolist()):
                fill(pal.SNOW, (x0, y0, size + 1, size + 1))
