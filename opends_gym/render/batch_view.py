"""`BatchDriverView`: the driver views of N Worlds drawn as display regions of shared buffers.

Why: an RL trainer on pixels steps many envs at once and wants their images together. Each
World keeps its own scene graph (`stage.Stage`, under its own root) and its own camera; the
cameras are display regions of offscreen buffers holding up to STRIP_VIEWS views side by side,
so a batch step is one `renderFrame` and one read per buffer, sliced into N images (the fixed
part of a frame, ~7 us of an 84x84 frame's ~45 us on the software pipe, is paid once per
buffer). Each env's image is its single driver view's for the same state, pixel for pixel
(the same camera, lens, card and scene; tested).

A view that needs more than one colour pass (fog or night: a depth pass; rain or snow; sun
shadows on an OpenGL pipe) is drawn by its own `DriverViewRenderer.render` that step, so
the images stay the single view's in every weather; its region in the batch is switched off.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .driver_view import CameraSlot, DriverViewRenderer
from .engine import Offscreen

BATCH_CARD_BIT = 30  # the batch cameras' background cards (the views' own cameras use 8 up; 31 is Panda3D's overall bit)
MAX_BUFFER_PX = 16384  # the widest buffer (OpenGL's usual texture limit)
# views per buffer: a batch of 64 84x84 views stepped at 6.4k env steps per CPU s in one buffer, 7.3k in
# buffers of 16 (9.5k for a batch of 16; the software pipe's frame slows as its buffer grows)
STRIP_VIEWS = 16
# the views of a buffer sit side by side in one row: a display region offset along x only gives
# the single view's pixels exactly, while regions stacked in rows drew the sky's shading a level
# or two apart (the software rasteriser's sub-pixel rounding differs with the region's y)


class BatchDriverView:
    """`render()` -> uint8 (N, height, width, 3): the ego driver view of each World."""

    def __init__(self, worlds: Sequence[Any], width: int, height: int, **options: Any) -> None:
        if not worlds:
            raise ValueError("BatchDriverView needs at least one World")
        self.width, self.height = int(width), int(height)
        self.views = [DriverViewRenderer(w, **options) for w in worlds]
        n = len(self.views)
        per = max(1, min(STRIP_VIEWS, MAX_BUFFER_PX // self.width))
        self.strips: list[tuple[int, int, Offscreen]] = []  # (first view, views, buffer)
        self.slots: list[CameraSlot] = []
        self.regions: list[Any] = []
        for first in range(0, n, per):
            count = min(per, n - first)
            target = Offscreen(self.width * count, self.height)
            for c in range(count):
                k = first + c
                slot = self.views[k].new_slot(f"batch{k}", BATCH_CARD_BIT)
                self.regions.append(target.region(c / count, (c + 1) / count, 0.0, 1.0, camera=slot.node, sort=c))
                self.slots.append(slot)
            self.strips.append((first, count, target))
        self._active = [True] * n
        self._out = np.empty((n, self.height, self.width, 3), np.uint8)

    def __len__(self) -> int:
        return len(self.views)

    def render(self) -> np.ndarray:
        """All views of the Worlds' current states (a new array each call)."""
        w, h = self.width, self.height
        own: list[int] = []
        for k, (view, slot) in enumerate(zip(self.views, self.slots)):
            alone = view.needs_post()
            if alone == self._active[k]:
                self.regions[k].setActive(not alone)
                self._active[k] = not alone
            if alone:
                own.append(k)
            else:
                view.stage_view(slot, w, h)
        out = self._out
        for first, count, target in self.strips:
            if not any(self._active[first : first + count]):
                continue
            target.render()
            # BGR(A), bottom row first, the views side by side: three plane copies (6 us a view
            # at 84x84 against 10 us for Panda3D's own conversion to RGB, `getRamImageAs`)
            raw = np.frombuffer(memoryview(target.color.getRamImage()), np.uint8)
            src = raw.reshape(h, count, w, -1)[::-1].transpose(1, 0, 2, 3)
            dst = out[first : first + count]
            dst[..., 0], dst[..., 1], dst[..., 2] = src[..., 2], src[..., 1], src[..., 0]
        for k in own:
            out[k] = self.views[k].render(w, h)
        return out.copy()

    def close(self) -> None:
        for _, _, target in self.strips:
            target.close()
