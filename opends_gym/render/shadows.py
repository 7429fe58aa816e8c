"""Sun shadows on the ground, where the graphics pipe has shaders (OpenGL), never on the software pipe.

Why: issue 20 asks for shadows "where the GPU allows". Panda3D casts a directional light's
shadows through its shader generator (`setShadowCaster` + `setShaderAuto`), which only a GSG
with shader support runs: OpenGL (`pandagl`, `p3headlessgl`), not `p3tinydisplay`. The option
(`shadows=` on the driver view and the human window, else `OPENDS_GYM_SHADOWS`) is

* `auto` (default): on where the pipe has shaders, off on the software pipe;
* `on`: shadows, or a one-line error naming the pipe where it has no shaders;
* `off`: never (the same pixels as the software pipe's frame, lighting aside).

What casts and what receives: every object (cars, signs, trees, buildings, pedestrians)
casts; the ground (asphalt, paint) receives. The ground is lit by the sun plus an ambient
light chosen so that sunlit ground keeps exactly its unlit colour (`GROUND_AMBIENT`) and shaded
ground shows that ambient share of it. Objects keep their baked shading (`meshes.boxes_node`).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .engine import PIPE_ENV, PIPES, panda, pipe_name, supports_shaders
from .stage import SHADOW_BIT

SHADOWS_ENV = "OPENDS_GYM_SHADOWS"
SHADOW_MODES = ("auto", "on", "off")
SHADOW_MAP_PX = 2048
SHADOW_AREA_M = 140.0  # side of the square around the viewer whose ground shows shadows
SUN_BACK_M = 150.0  # the shadow camera stands this far up-sun of the viewer


def shadow_mode(option: str | None = None) -> str:
    """The shadow option: `option`, else `OPENDS_GYM_SHADOWS`, else "auto"."""
    raw = option if option is not None else os.environ.get(SHADOWS_ENV, "auto")
    mode = str(raw).strip().lower() or "auto"
    if mode not in SHADOW_MODES:
        where = "shadows" if option is not None else SHADOWS_ENV
        raise ValueError(f"{where}={raw!r}: choose one of {', '.join(SHADOW_MODES)}")
    return mode


def shadows_wanted(mode: str) -> bool:
    """Whether shadows are drawn for `mode` on this process's pipe ("on" without shaders: error)."""
    if mode == "off":
        return False
    ok = supports_shaders()
    if mode == "on" and not ok:
        name = pipe_name()
        raise RuntimeError(
            f"shadows='on' needs a graphics pipe with shaders; {PIPES[name]} ({PIPE_ENV}={name}) has none: "
            f"set {PIPE_ENV}=gl or egl on a machine with OpenGL, or use shadows='auto'"
        )
    return ok


def ground_ambient(sun_color: float, sun_dir: tuple[float, float, float]) -> float:
    """The ambient level that, with the sun on flat ground, gives exactly 1 (the unlit colour)."""
    d = np.asarray(sun_dir, float)
    cos_up = -d[2] / float(np.linalg.norm(d))  # Panda3D z up; the direction the light travels
    return max(0.0, 1.0 - sun_color * cos_up)


def enable(stage: Any, sun_dir: tuple[float, float, float]) -> None:
    """Make the stage's sun cast shadows onto its ground (once; the GSG must run shaders)."""
    p3d = panda()
    sun = stage.sun.node()
    sun_color = float(sun.getColor()[1])
    sun.setShadowCaster(True, SHADOW_MAP_PX, SHADOW_MAP_PX)
    # the shadow camera sees what casts (objects, cars, the ego) and not the ground, which would
    # shade itself (it lies in the depth it is compared against)
    sun.setCameraMask(p3d.BitMask32.bit(SHADOW_BIT))
    stage.ground.hide(p3d.BitMask32.bit(SHADOW_BIT))
    stage.ego.np.show(p3d.BitMask32.bit(SHADOW_BIT))
    sun.setDirection(p3d.LVector3(0.0, 1.0, 0.0))  # along the node's own +Y: `follow` turns the node to the sun's direction
    lens = sun.getLens()
    lens.setFilmSize(SHADOW_AREA_M, SHADOW_AREA_M)
    lens.setNearFar(1.0, 2.0 * SUN_BACK_M)
    amb = p3d.AmbientLight("ground-ambient")
    a = ground_ambient(sun_color, sun_dir)
    amb.setColor((a, a, a, 1.0))
    ground_amb = stage.root.attachNewNode(amb)
    for layer in (stage.ground,):
        add_up_normals(layer)
        layer.clearLight()
        layer.setLight(ground_amb)
        layer.setLight(stage.sun)
    stage.root.setShaderAuto()
    follow(stage, 0.0, 0.0, 0.0, sun_dir)


def follow(stage: Any, x: float, y: float, z: float, sun_dir: tuple[float, float, float]) -> None:
    """Put the shadow camera up-sun of the viewer at world (x, y, z) (Panda3D (x, -z, y))."""
    d = np.asarray(sun_dir, float) / float(np.linalg.norm(sun_dir))
    px, py, pz = x, -z, y
    stage.sun.setPos(px - d[0] * SUN_BACK_M, py - d[1] * SUN_BACK_M, pz - d[2] * SUN_BACK_M)
    stage.sun.lookAt(px, py, pz)


def add_up_normals(node_path: Any) -> None:
    """Give every Geom under `node_path` an up normal per vertex (lighting needs normals; the
    flat ground meshes are built without them for the software pipe)."""
    from .meshes import vertex_format

    p3d = panda()
    for gnp in node_path.findAllMatches("**/+GeomNode"):
        node = gnp.node()
        for i in range(node.getNumGeoms()):
            geom = node.modifyGeom(i)
            vdata = geom.modifyVertexData()
            if vdata.getFormat().hasColumn(p3d.InternalName.getNormal()):
                continue
            uv = vdata.getFormat().hasColumn(p3d.InternalName.getTexcoord())
            vdata.setFormat(vertex_format(True, uv))
            writer = p3d.GeomVertexWriter(vdata, "normal")
            for _ in range(vdata.getNumRows()):
                writer.setData3f(0.0, 0.0, 1.0)
