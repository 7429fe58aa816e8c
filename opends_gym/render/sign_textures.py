"""Procedural sign faces: a board colour, a white border and the label, drawn once per look.

Why: the LCT's lane signs must be legible at 40 m on a 1920x1080 screen and OpenDS's sign
textures are not ours to ship. A board's face is drawn with pygame's bundled font into a
texture (mipmapped, so a far sign stays readable instead of shimmering): blue lane boards
with their lane number, red BRAKE panels, speed limits as a red ring around the number.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from . import _pg
from .engine import panda
from .palette import RGB

TEX_H = 128
_CACHE: dict[tuple[str, RGB, int], Any] = {}


def face_image(label: str, color: RGB, aspect: float, key: str = "") -> np.ndarray:
    """The sign face as uint8 (TEX_H, power-of-two width, 3), top row first."""
    pg = _pg.pygame()
    h = TEX_H
    w = int(max(32, min(1024, round(h * max(aspect, 0.25)))))
    s = _pg.new_surface(w, h)
    limit = re.search(r"speedlimit(\d+)", key.lower())
    if limit:
        s.fill((245, 245, 245))
        r = min(w, h) // 2 - 2
        pg.draw.circle(s, (200, 20, 20), (w // 2, h // 2), r)
        pg.draw.circle(s, (250, 250, 250), (w // 2, h // 2), int(r * 0.78))
        label, fg = limit.group(1), (15, 15, 15)
    else:
        s.fill(color)
        border = max(2, h // 24)
        pg.draw.rect(s, (245, 245, 245), s.get_rect(), border)
        fg = (250, 250, 250)
    if label:
        img = _pg.font(int(h * 0.8), True).render(label, True, fg)
        scale = min(0.86 * w / img.get_width(), 0.78 * h / img.get_height())
        img = pg.transform.smoothscale_by(img, scale)
        s.blit(img, img.get_rect(center=(w // 2, h // 2)))
    tex_w = 1 << max(5, (w - 1).bit_length())  # a power-of-two texture (the software renderer needs one), stretched back by the UVs
    return _pg.to_array(pg.transform.smoothscale(s, (tex_w, h)))


def face_texture(label: str, color: RGB, aspect: float, key: str = "") -> Any:
    """A Panda3D texture of `face_image` (cached per look)."""
    ck = (label + "|" + key, color, int(round(aspect * 4)))
    tex = _CACHE.get(ck)
    if tex is None:
        p3d = panda()
        img = face_image(label, color, aspect, key)
        h, w = img.shape[:2]
        tex = p3d.Texture(f"sign-{label}")
        tex.setup2dTexture(w, h, p3d.Texture.TUnsignedByte, p3d.Texture.FRgb)
        tex.setRamImageAs(np.ascontiguousarray(img[::-1]).tobytes(), "RGB")
        tex.setMinfilter(p3d.SamplerState.FTLinearMipmapLinear)
        tex.setMagfilter(p3d.SamplerState.FTLinear)
        tex.setWrapU(p3d.SamplerState.WMClamp)
        tex.setWrapV(p3d.SamplerState.WMClamp)
        _CACHE[ck] = tex
    return tex
