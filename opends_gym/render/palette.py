"""Colours of the synthetic world (RGB 0..255) and small colour arithmetic.

Why: both views and the HUD must agree on what a road, a marking or a lit brake light
looks like; tests check for these colours, so they live in one place.
"""

from __future__ import annotations

import numpy as np

RGB = tuple[int, int, int]

SKY_ZENITH: RGB = (92, 142, 206)
SKY_HORIZON: RGB = (186, 208, 232)
GRASS: RGB = (92, 132, 70)
GRASS_FAR: RGB = (120, 150, 100)
ASPHALT: RGB = (96, 96, 100)
SHOULDER: RGB = (124, 120, 112)
MARKING: RGB = (240, 240, 240)
IDEAL_TRACK: RGB = (40, 210, 230)
FOG: RGB = (200, 202, 206)
RAIN: RGB = (170, 180, 200)
SNOW: RGB = (250, 250, 252)

EGO: RGB = (220, 60, 40)
TRAFFIC_BODIES: tuple[RGB, ...] = ((60, 90, 170), (200, 200, 205), (40, 40, 45), (150, 30, 35), (60, 120, 80), (190, 160, 60))
BRAKE_ON: RGB = (255, 40, 30)
BRAKE_OFF: RGB = (110, 25, 25)
SIGNAL_ON: RGB = (255, 170, 0)
SIGNAL_OFF: RGB = (120, 90, 40)
GLASS: RGB = (60, 70, 85)

LIGHT_HOUSING: RGB = (35, 35, 35)
LAMP_RED: RGB = (255, 30, 20)
LAMP_YELLOW: RGB = (255, 200, 0)
LAMP_GREEN: RGB = (40, 230, 70)
LAMP_DARK: RGB = (55, 55, 55)

TRIGGER_DEBUG: RGB = (230, 0, 230)
METAL: RGB = (150, 154, 160)

HUD_TEXT: RGB = (235, 235, 235)
HUD_BG: RGB = (20, 20, 24)
WARNING: RGB = (230, 20, 20)


def blend(a: RGB, b: RGB, t: float) -> RGB:
    """a*(1-t) + b*t, t clamped to [0, 1]."""
    t = min(1.0, max(0.0, t))
    return (int(a[0] + (b[0] - a[0]) * t), int(a[1] + (b[1] - a[1]) * t), int(a[2] + (b[2] - a[2]) * t))


def shade(c: RGB, f: float) -> RGB:
    return (min(255, int(c[0] * f)), min(255, int(c[1] * f)), min(255, int(c[2] * f)))


def blend_rows(colors: np.ndarray, target: RGB, t: np.ndarray) -> np.ndarray:
    """Vectorised blend of (N, 3) colours toward one target by per-row weights t (N,)."""
    t = np.clip(t, 0.0, 1.0)[:, None]
    return colors * (1.0 - t) + np.asarray(target, dtype=float) * t
