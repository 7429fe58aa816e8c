"""Panda3D bootstrap: one offscreen colour+depth buffer per renderer, read back as numpy.

Why: the 3D views run on servers with no display and often no GPU, and on lab machines
with one. Panda3D (the engine MetaDrive uses) renders into offscreen buffers through its
software rasteriser (`p3tinydisplay`, deterministic, no GL needed) or through OpenGL
(`pandagl`, or `p3headlessgl` = EGL without an X server). The pipe is chosen by
`OPENDS_GYM_RENDER_PIPE` (tinydisplay | gl | egl; default tinydisplay, so the same world
state gives the same pixels on every machine). Panda3D is imported on first use only.

Panda3D is Z-up with +Y forward; OpenDS (jME) is Y-up with -Z forward. A world point
(x, y, z) is Panda (x, -z, y); a yaw (positive = left) is Panda's heading in degrees.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

PIPES = {"tinydisplay": "p3tinydisplay", "gl": "pandagl", "egl": "p3headlessgl"}
PIPE_ENV = "OPENDS_GYM_RENDER_PIPE"
_STATE: dict[str, Any] = {}
# frames up to this many pixels are read through `Texture.getRamImageAs` (84x84: 6.6 against 9.7 us
# of CPU); larger ones through numpy's plane copies (1280x720: 1.1 against 2.2 ms)
SMALL_FRAME_PX = 256 * 256

PRC = """
window-type none
audio-library-name null
sync-video false
framebuffer-multisample 0
notify-level-display fatal
notify-level-x11display fatal
notify-level-glxdisplay fatal
notify-level-tinydisplay fatal
notify-level-egldisplay fatal
notify-level-gobj error
textures-power-2 none
model-cache-dir
"""


def panda() -> Any:
    """The `panda3d.core` module, configured for offscreen rendering on first use."""
    core = _STATE.get("core")
    if core is None:
        from panda3d import core as p3d

        p3d.loadPrcFileData("opends_gym", PRC)
        core = _STATE["core"] = p3d
    return core


def pipe_name() -> str:
    name = os.environ.get(PIPE_ENV, "tinydisplay").strip().lower() or "tinydisplay"
    if name not in PIPES:
        raise ValueError(f"{PIPE_ENV}={name!r}: choose one of {', '.join(PIPES)}")
    return name


def graphics_pipe() -> Any:
    """The process's graphics pipe (made once; every renderer shares it)."""
    name = pipe_name()
    pipe = _STATE.get("pipe:" + name)
    if pipe is None:
        p3d = panda()
        pipe = p3d.GraphicsPipeSelection.getGlobalPtr().makeModulePipe(PIPES[name])
        if pipe is None:
            raise RuntimeError(f"Panda3D graphics pipe {PIPES[name]!r} is not available here (set {PIPE_ENV}=tinydisplay)")
        _STATE["pipe:" + name] = pipe
    return pipe


def supports_shaders() -> bool:
    """Whether this process's pipe runs shaders (Panda3D's shader generator): never the software
    renderer; an OpenGL pipe is asked once through a 4x4 buffer's GSG."""
    name = pipe_name()
    if name == "tinydisplay":
        return False
    key = "shaders:" + name
    if key not in _STATE:
        probe = Offscreen(4, 4)
        probe.engine.openWindows()
        gsg = probe.buffer.getGsg()
        _STATE[key] = bool(gsg is not None and gsg.getSupportsBasicShaders())
        probe.close()
    return bool(_STATE[key])


class Offscreen:
    """An offscreen buffer of `width` x `height` with its own engine; `rgb()` reads the last frame."""

    def __init__(self, width: int, height: int, clear: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        p3d = panda()
        pipe = graphics_pipe()
        self.width, self.height = int(width), int(height)
        self.engine = p3d.GraphicsEngine(pipe)
        fb = p3d.FrameBufferProperties()
        fb.setRgbColor(True)
        fb.setRgbaBits(8, 8, 8, 0)
        fb.setDepthBits(24)
        props = p3d.WindowProperties.size(self.width, self.height)
        flags = p3d.GraphicsPipe.BFRefuseWindow
        self.buffer = self.engine.makeOutput(pipe, "opends_gym", 0, fb, props, flags)
        if self.buffer is None:
            raise RuntimeError(f"Panda3D could not open a {width}x{height} offscreen buffer on {pipe.getInterfaceName()}")
        self.buffer.setClearColor((*clear, 1.0))
        self.buffer.getDisplayRegion(0).setActive(False)
        self.color = p3d.Texture("color")
        self.buffer.addRenderTexture(self.color, p3d.GraphicsOutput.RTMCopyRam, p3d.GraphicsOutput.RTPColor)

    def region(self, left: float, right: float, bottom: float, top: float, camera: Any, sort: int = 0) -> Any:
        """A display region (fractions from the bottom-left, as jME viewports) shown by `camera`."""
        dr = self.buffer.makeDisplayRegion(left, right, bottom, top)
        dr.setCamera(camera)
        dr.setSort(sort)
        dr.setClearDepthActive(True)
        return dr

    def render(self) -> None:
        self.engine.renderFrame()

    def rgb(self) -> np.ndarray:
        """The last frame as a writable uint8 (height, width, 3), top row first."""
        if self.width * self.height <= SMALL_FRAME_PX:  # Panda3D's own BGRA->RGB, then one flipped copy
            rgb = np.frombuffer(self.color.getRamImageAs("RGB"), np.uint8).reshape(self.height, self.width, 3)
            return rgb[::-1].copy()
        raw = np.frombuffer(memoryview(self.color.getRamImage()), np.uint8)
        bgr = raw.reshape(self.height, self.width, -1)[::-1]
        out = np.empty((self.height, self.width, 3), np.uint8)
        out[..., 0], out[..., 1], out[..., 2] = bgr[..., 2], bgr[..., 1], bgr[..., 0]  # (three plane copies beat one strided copy)
        return out

    def bgra_bytes(self) -> Any:
        """The last frame's raw bytes (BGRA or BGR, bottom row first) for a fast blit."""
        return memoryview(self.color.getRamImage())

    def components(self) -> int:
        return int(self.color.getNumComponents())

    def close(self) -> None:
        if self.buffer is not None:
            self.engine.removeAllWindows()
            self.buffer = None
