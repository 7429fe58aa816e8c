"""Lazy pygame access and the few surface helpers every renderer needs.

Why: importing `opends_gym.render` must not import pygame, open a display or print the
pygame banner; rendering happens on headless servers, so everything here works on plain
offscreen Surfaces (no display, no GL context).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

_MODULE: list[Any] = []


def pygame() -> Any:
    """The pygame module, imported on first use (with its start-up banner silenced)."""
    if not _MODULE:
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        import pygame as pg

        _MODULE.append(pg)
    return _MODULE[0]


def new_surface(width: int, height: int) -> Any:
    """An offscreen 24-bit RGB surface (no display needed)."""
    pg = pygame()
    return pg.Surface((int(width), int(height)), 0, 24)


def to_array(surface: Any) -> np.ndarray:
    """The surface as a writable uint8 array of shape (height, width, 3)."""
    pg = pygame()
    w, h = surface.get_size()
    return np.frombuffer(pg.image.tobytes(surface, "RGB"), dtype=np.uint8).reshape(h, w, 3).copy()


def from_array(frame: np.ndarray) -> Any:
    """A surface holding an (height, width, 3) uint8 frame."""
    pg = pygame()
    frame = np.ascontiguousarray(frame, dtype=np.uint8)
    h, w = frame.shape[:2]
    return pg.image.frombuffer(frame.tobytes(), (w, h), "RGB")


_FONTS: dict[tuple[int, bool], Any] = {}


def font(size_px: int, bold: bool = False) -> Any:
    """pygame's bundled default font at a pixel size (cached; works headless; survives pygame.quit())."""
    pg = pygame()
    if not pg.font.get_init():
        _FONTS.clear()
        pg.font.init()
    key = (max(6, int(size_px)), bool(bold))
    f = _FONTS.get(key)
    if f is None:
        f = _FONTS[key] = pg.font.Font(None, key[0])
        f.set_bold(bold)
    return f


def text(surface: Any, s: str, pos: tuple[float, float], size_px: int, color: tuple[int, int, int], anchor: str = "topleft") -> Any:
    """Draw a line of text; `anchor` is a pygame Rect attribute (topleft, center, midbottom...)."""
    img = font(size_px).render(s, True, color)
    rect = img.get_rect(**{anchor: (int(pos[0]), int(pos[1]))})
    surface.blit(img, rect)
    return rect
