"""`Stage`: a World's Panda3D scene graph, built once, with only transforms updated per frame.

Why: image observations need thousands of frames per second, so nothing is rebuilt per
step. The road (every source `RoadLayout` knows: OpenDS lanes, OpenDRIVE, the LCT bands,
Gen A/B waypoint roads, the ego's start connector) becomes static meshes; scene models,
traffic cars, pedestrians, traffic lights and the ego car are nodes built on first sight
whose pose, visibility and lamp colours `sync()` copies from the World.

Ground layers (the cameras' sky-and-grass cards, asphalt, markings) are drawn first in a fixed order without
depth test or write: no z-fighting between grass, road and paint at any distance. Objects
are drawn over them with depth; models whose top lies below the ground are not drawn.
"""

from __future__ import annotations

import fnmatch
import json
import math
import operator
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import meshes
from . import palette as pal
from .engine import panda
from .road_layout import DASH_M, MARK_HALF_W_M, PERIOD_M, RoadLayout
from .scene import BLINK_HZ, LAMPS_BY_STATE, LIGHT_HOUSING_M, LIGHT_POLE_M, WorldScene
from .styles import Part, base_y, car_parts

MODEL_MAP_ENV = "OPENDS_GYM_MODEL_MAP"
GRASS_RINGS = [(r, pal.blend(pal.GRASS, pal.GRASS_FAR, r / 400.0)) for r in (8.0, 30.0, 100.0, 400.0, 1900.0)]
DASHES_M = 306.0  # dashes further than this are below a pixel wide at 1920x1080: left out (low-poly LOD)
BAND_HALF_LENGTH_M = 1080.0  # the LCT's endless straight lanes: a 2 km piece that follows the viewer
# the band's cells along it: behind, around and ahead of the viewer (who stays within half a dash
# period of the middle), so a camera looking ahead culls the 1 km behind it whole instead of
# clipping it triangle by triangle (15 of 75 us of an 84x84 frame on the software pipe)
BAND_CELLS_M = (-24.0, 24.0)
# paint further than this along the band is left out of small frames: at 84x84 (focal 87 px) a
# 15 cm line there is 0.14 px wide and a 6 m dash 0.07 px tall, so it only ever lit a pixel by
# aliasing, yet its triangles cost 11 of 70 us of the frame on the software pipe
FAR_PAINT_M = 96.0
DETAIL_FOCAL_PX = 160.0  # cameras with at least this focal length (a line there 1/4 px wide) draw the far paint
BURIED_TRAFFIC_M = 5.0  # traffic parked this far below the ego is not drawn (init_drive parks pedestrians at -50 m)
SUN_DIR = (-0.45, -0.38, -0.8)  # Panda3D (x, y, z) direction the sunlight travels
ORDER_SKY, ORDER_GRASS, ORDER_ROAD, ORDER_MARK, ORDER_TRACK = 0, 1, 2, 3, 4
# camera masks (a node shows to a camera that has one of the node's shown bits): the ego shows to
# cameras outside it and to the map, the grass disc only to the fog's depth pass, map symbols
# (wide lines, ideal tracks, lamps seen from above, traffic-light discs) only to the map,
# camera k's background card only to camera k, and the far paint (FAR_PAINT_M) only to cameras
# with DETAIL_BIT (large frames), the map and the depth pass
INSIDE_BIT, OUTSIDE_BIT, DEPTH_BIT, MAP_BIT, DETAIL_BIT, CARD_BIT0 = 1, 2, 3, 4, 5, 8
SHADOW_BIT = 6  # the sun's shadow camera (shadows.py): what casts shadows
MAP_LINE_PX = 1.2
GROUND_CELL_M = 250.0  # map lines are at least this wide (thinner ones would miss pixel centres)
LIGHT_DISC_M = 0.6
_OBJECT_POSE = operator.attrgetter("visible", "position", "yaw", "scale")
MAP_FOOTPRINT_M = 0.6  # half size: a sign board seen from above is a few centimetres thin
MAP_LIGHT_COLORS = {
    (True, False, False): pal.LAMP_RED,
    (False, True, False): pal.LAMP_YELLOW,
    (False, False, True): pal.LAMP_GREEN,
    (True, True, False): pal.LAMP_YELLOW,
    (True, True, True): pal.LAMP_YELLOW,
}


def bits(*names: int) -> Any:
    """A camera or show mask of the given bits."""
    p3d = panda()
    mask = p3d.BitMask32()
    for b in names:
        mask |= p3d.BitMask32.bit(b)
    return mask


def only_for(node: Any, *names: int) -> Any:
    """Show `node` only to cameras with one of these bits."""
    node.hide(panda().BitMask32.allOn())
    node.show(bits(*names))
    return node


def _rgba(c: tuple[int, int, int] | tuple[float, ...]) -> tuple[float, float, float, float]:
    """0..255 to 0..1, a little over each level so renderers that truncate keep the exact value."""
    return (min(1.0, (c[0] + 0.1) / 255.0), min(1.0, (c[1] + 0.1) / 255.0), min(1.0, (c[2] + 0.1) / 255.0), 1.0)


def band_breaks(first_m: float = 6.0, growth: float = 1.35) -> tuple[np.ndarray, np.ndarray]:
    """Piece ends (z0, z1) along an endless band: short pieces near the viewer (exact software
    clipping at the near plane), longer ones further away (few triangles)."""
    out = [0.0, first_m]
    while out[-1] < BAND_HALF_LENGTH_M:
        out.append(min(BAND_HALF_LENGTH_M, out[-1] + first_m * growth ** len(out)))
    edges = np.concatenate([-np.asarray(out[:0:-1]), np.asarray(out)])
    return edges[:-1], edges[1:]


def load_model_map(path: str | os.PathLike[str] | None) -> dict[str, str]:
    """{OpenDS model key or glob: glTF/BAM/EGG file} from a JSON file (relative files are next to it)."""
    if path is None:
        path = os.environ.get(MODEL_MAP_ENV) or None
        if path is None:
            return {}
    p = Path(path)
    try:
        raw = json.loads(p.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{p}: model map is not a readable JSON object: {e}") from None
    if not isinstance(raw, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in raw.items()):
        raise ValueError(f"{p}: model map must map OpenDS model keys to file paths (strings)")
    return {k: str((p.parent / v) if not Path(v).is_absolute() else Path(v)) for k, v in raw.items()}


class Stage:
    """The scene graph of one World (see the module docstring)."""

    def __init__(self, world: Any, show_triggers: bool = False, model_map: str | os.PathLike[str] | dict[str, str] | None = None) -> None:
        p3d = panda()
        self.world = world
        self.scene = WorldScene(world, show_triggers=show_triggers)
        self.road = RoadLayout(world)
        self.model_map = model_map if isinstance(model_map, dict) else load_model_map(model_map)
        self.root = p3d.NodePath("world")
        self.root.setTwoSided(True)
        self.root.setTransparency(p3d.TransparencyAttrib.MNone)
        self.ground = self.root.attachNewNode("ground")
        self.ground.setLightOff(1)
        self.background = self.root.attachNewNode("backgrounds")  # the cameras' cards hang under their cameras
        self.objects = self.root.attachNewNode("objects")
        self._lights()
        # sky and grass: each camera carries a background card (driver_view); the grass disc is
        # drawn only in the fog's depth pass, where the ground's distance matters
        self.grass = self._ground_layer(meshes.disc_node("grass", GRASS_RINGS, segments=20), ORDER_GRASS)
        self.road_np = self.ground.attachNewNode("road")
        self._build_road()
        self._scene_nodes: dict[int, Any] = {}
        self._scene_state: dict[int, tuple[Any, ...]] = {}
        self._scene_scale: dict[int, tuple[float, float, float]] = {}
        self._traffic: dict[int, CarNode | Any] = {}
        self._lights_nodes = [TrafficLightNode(self.objects, p) for p in self.scene.lights]
        self.ego = CarNode(self.objects, car_parts(*self._ego_size(), pal.EGO))
        hx, hz, height = self._ego_size()
        body = car_parts(hx, hz, height, pal.EGO)[0]  # the bonnet, for OpenDS's `showHood` (driver_view shows it)
        self.hood = self.objects.attachNewNode(
            meshes.boxes_node("hood", (Part(0.0, -0.72 * hz, body.y0, body.y1, hx, 0.28 * hz, pal.EGO),))
        )
        only_for(self.hood, INSIDE_BIT)
        self.hood.hide(panda().BitMask32.allOn())  # until driver_view asks for it (showHood)
        only_for(self.ego.np, OUTSIDE_BIT, MAP_BIT)
        only_for(self.grass, DEPTH_BIT)
        self.show_hood = False
        self._map_key: tuple[float, bool] | None = None
        self._map_nodes: list[Any] = []
        self._ground_y: float | None = None
        self._band_y: float | None = None
        self._cam = (0.0, 0.0)
        self._light_objects = {p.object_id for p in self.scene.lights if p.object_id}
        self._watched = [o for o in world.objects.objects if o.id not in self._light_objects and (show_triggers or not o.is_trigger)]
        self._scene_sig: tuple[Any, ...] = ()

    # ------------------------------------------------------------------ building
    def _lights(self) -> None:
        p3d = panda()
        amb = p3d.AmbientLight("ambient")
        amb.setColor((0.62, 0.62, 0.64, 1.0))
        sun = p3d.DirectionalLight("sun")
        sun.setColor((0.5, 0.5, 0.46, 1.0))
        sun.setDirection(p3d.LVector3(*SUN_DIR))
        self.ambient = self.root.attachNewNode(amb)
        self.sun = self.root.attachNewNode(sun)
        self.objects.setLightOff(1)  # our meshes carry baked shading; the user's own models get the lights

    def _ground_layer(self, node: Any, order: int, parent: Any = None) -> Any:
        np_ = (parent or self.ground).attachNewNode(node)
        np_.setBin("background", order)
        np_.setDepthTest(False)
        np_.setDepthWrite(False)
        return np_

    def _build_road(self) -> None:
        road = self.road
        white = np.asarray(pal.MARKING, np.float32)
        layers: list[tuple[np.ndarray, np.ndarray]] = []  # (quads (N, 4, 2), colours (N, 3)) in drawing order
        marks: list[np.ndarray] = []
        for r in road.ribbons:
            q = np.stack([r.left[:-1], r.left[1:], r.right[1:], r.right[:-1]], axis=1)
            layers.append((q, np.tile(np.asarray(r.color, np.float32), (len(q), 1))))
            for pts, dashed in r.marks:
                lines = np.concatenate([pts[:-1], pts[1:]], axis=1)
                if dashed:
                    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
                    lines = lines[(0.5 * (s[:-1] + s[1:])) % PERIOD_M < DASH_M]
                if len(lines):
                    marks.append(lines)
        self.ribbon_lines = np.concatenate(marks) if marks else np.zeros((0, 4))
        self._ground_cells("road", layers, self.road_np, ORDER_ROAD)
        if marks:
            q = meshes.line_quads_xz(self.ribbon_lines, MARK_HALF_W_M)
            self._ground_cells("paint", [(q, np.tile(white, (len(q), 1)))], self.road_np, ORDER_MARK)
        self.bands = None
        self.band_lines = np.zeros((0, 4))
        if road.bands:
            self.bands = self.ground.attachNewNode("bands")
            lo, hi = road.band_x
            z0, z1 = band_breaks()
            quad = np.stack([np.stack([np.full_like(z0, lo), z0], 1), np.stack([np.full_like(z0, hi), z0], 1),
                             np.stack([np.full_like(z0, hi), z1], 1), np.stack([np.full_like(z0, lo), z1], 1)], 1)  # fmt: skip
            band_lines: list[np.ndarray] = []
            k = np.arange(-DASHES_M, DASHES_M, PERIOD_M)
            for e, dashed in road.band_marks:
                if dashed:
                    band_lines.append(np.stack([np.full_like(k, e), k, np.full_like(k, e), k + DASH_M], axis=1))
                else:
                    band_lines.append(np.stack([np.full_like(z0, e), z0, np.full_like(z0, e), z1], axis=1))
            self.band_lines = np.concatenate(band_lines)
            q = meshes.line_quads_xz(self.band_lines, MARK_HALF_W_M)
            asphalt = np.tile(np.asarray(pal.ASPHALT, np.float32), (len(quad), 1))
            self._ground_cells("band", [(quad, asphalt)], self.bands, ORDER_ROAD, splits=BAND_CELLS_M)
            paint_splits = (-FAR_PAINT_M, *BAND_CELLS_M, FAR_PAINT_M)
            cells = self._ground_cells("band-paint", [(q, np.tile(white, (len(q), 1)))], self.bands, ORDER_MARK, splits=paint_splits)
            for cell, node in cells:
                if cell in (0, len(paint_splits)):  # beyond FAR_PAINT_M, ahead or behind
                    only_for(node, DETAIL_BIT, MAP_BIT, DEPTH_BIT)

    def _ground_cells(
        self,
        name: str,
        layers: list[tuple[np.ndarray, np.ndarray]],
        parent: Any,
        order: int,
        cell_m: float = GROUND_CELL_M,
        splits: Sequence[float] | None = None,
    ) -> list[tuple[int, Any]]:
        """One mesh per `cell_m` square (or, given `splits`, per slice along Z between them) of a
        ground layer: few meshes to draw, and Panda3D culls the cells out of view. Quads keep
        their order inside a cell. Returns (cell index along Z, node) per mesh."""
        if not layers:
            return []
        quads = np.concatenate([q for q, _ in layers]).astype(np.float32)
        colors = np.concatenate([c for _, c in layers])
        centre = quads.mean(axis=1)
        cell = np.floor(centre / cell_m).astype(np.int64)
        if splits is not None:
            cell[:, 0] = 0
            cell[:, 1] = np.digitize(centre[:, 1], np.asarray(splits))
        key = cell[:, 0] * 1_000_003 + cell[:, 1]
        idx = np.argsort(key, kind="stable")
        key, quads, colors = key[idx], quads[idx], colors[idx]
        starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
        out = []
        for a, b in zip(starts, [*starts[1:], len(key)]):
            node = self._ground_layer(meshes.flat_quads_node(name, quads[a:b], colors[a:b]), order, parent=parent)
            out.append((int(key[a] % 1_000_003), node))
        return out

    def map_symbols(self, scale_px_per_m: float, ideal_tracks: bool) -> None:
        """(Re)build the map's wide lane lines and ideal tracks for a scale (at least `MAP_LINE_PX` wide)."""
        key = (round(max(MARK_HALF_W_M, 0.5 * MAP_LINE_PX / scale_px_per_m), 3), ideal_tracks)
        if key == self._map_key:
            return
        for node in self._map_nodes:
            node.removeNode()
        self._map_nodes = []
        half_w = key[0]
        white = np.asarray(pal.MARKING, np.float32)
        for lines, parent in ((self.ribbon_lines, self.road_np), (self.band_lines, self.bands)):
            if len(lines) and parent is not None:
                q = meshes.line_quads_xz(lines, half_w)
                node = self._ground_layer(meshes.flat_quads_node("map-marks", q, np.tile(white, (len(q), 1))), ORDER_MARK, parent=parent)
                self._map_nodes.append(only_for(node, MAP_BIT))
        if ideal_tracks and self.road.tracks:
            lines = np.concatenate([np.concatenate([xz[:-1], xz[1:]], axis=1) for xz in self.road.tracks if len(xz) > 1])
            q = meshes.line_quads_xz(lines, 0.5 * MAP_LINE_PX / scale_px_per_m)
            cyan = np.tile(np.asarray(pal.IDEAL_TRACK, np.float32), (len(q), 1))
            node = self._ground_layer(meshes.flat_quads_node("ideal-tracks", q, cyan), ORDER_TRACK, parent=self.road_np)
            self._map_nodes.append(only_for(node, MAP_BIT))
        self._map_key = key

    def _ego_size(self) -> tuple[float, float, float]:
        box = self.world.ego_obb()
        return box.hx, box.hz, self.world.ego.spec.height_m

    # ------------------------------------------------------------------ per frame
    def sync(self, cam_x: float, cam_y: float, cam_z: float, include_ego: bool) -> None:
        """Copy the World's current state into the scene graph for a camera at (x, y, z)."""
        w = self.world
        ground_y = w.ego.state.y
        if ground_y != self._ground_y:
            self.ground.setZ(ground_y)
            self._ground_y = ground_y
        self._cam = (cam_x, cam_z)
        if self.bands is not None:
            band_y = -round(cam_z / PERIOD_M) * PERIOD_M
            if band_y != self._band_y:
                self.bands.setY(band_y)
                self._band_y = band_y
        blink_on = math.floor(w.t_s * 2.0 * BLINK_HZ) % 2 == 0
        self._sync_scene(ground_y)
        self._sync_traffic(ground_y, blink_on)
        for node in self._lights_nodes:
            node.sync(self.scene, w)
        if include_ego or self.show_hood:  # (the ego shows only to cameras outside it: driver_view's masks)
            box = w.ego_obb()
            if self.show_hood:
                self.hood.setPosHpr(box.cx, -box.cz, ground_y, math.degrees(box.yaw), 0.0, 0.0)
            inputs = w.ego.inputs
            signal = {"left": 1, "right": 2, "both": 3}.get(str(inputs.turn_signal), 0)
            self.ego.sync(box.cx, ground_y, box.cz, box.yaw, inputs.brake > 0.02, signal, blink_on)

    def place_grass(self) -> None:
        """Centre the grass disc (drawn only by the fog's depth pass) under the last camera."""
        self.grass.setPos(self._cam[0], -self._cam[1], 0.0)

    def _sync_scene(self, ground_y: float) -> None:
        objs = self._watched
        sig = (list(map(_OBJECT_POSE, objs)), ground_y)  # (attrgetter: a third of the cost of list comprehensions)
        if sig == self._scene_sig:
            return  # nothing moved, appeared or disappeared since the last frame (the usual case)
        self._scene_sig = sig
        show_triggers = self.scene.show_triggers
        for o in objs:
            seen = (o.visible and not o.is_trigger) or (o.is_trigger and show_triggers)
            if seen and not o.is_trigger and base_y(o) + 2 * o.half[1] < ground_y:
                seen = False  # buried under the ground the view draws (as OpenDS's terrain would hide it)
            key = o.index
            node = self._scene_nodes.get(key)
            if not seen:
                if node is not None and self._scene_state.get(key, (False,))[0]:
                    node.hide()
                    self._scene_state[key] = (False,)
                continue
            state = (True, o.position, o.yaw, o.scale)
            if self._scene_state.get(key) == state:
                continue
            if node is None or self._scene_scale.get(key) != o.scale:
                if node is not None:
                    node.removeNode()
                node = self._scene_nodes[key] = self._object_node(o, self.scene.parts(o))
                self._scene_scale[key] = o.scale
            node.show()
            node.setPosHpr(o.position[0], -o.position[2], base_y(o), math.degrees(o.yaw), 0.0, 0.0)
            self._scene_state[key] = state

    def _object_node(self, o: Any, parts: tuple[Part, ...]) -> Any:
        model = self.scene.models[o.index] if 0 <= o.index < len(self.scene.models) else None
        key = (model.key if model is not None else "") or ""
        custom = self._custom_model(key, o)
        if custom is not None:
            return custom
        node = self.objects.attachNewNode(meshes.boxes_node(f"obj{o.index}", object_parts(key, parts, o), shade=not o.is_trigger))
        if parts and not o.is_trigger:  # on the map: the widest part's footprint, never thinner than MAP_FOOTPRINT_M
            p = max(parts, key=lambda q: q.hx * q.hz)
            hx, hz = max(p.hx, MAP_FOOTPRINT_M), max(p.hz, MAP_FOOTPRINT_M)
            quad = np.array([[[p.dx - hx, p.dz - hz], [p.dx + hx, p.dz - hz], [p.dx + hx, p.dz + hz], [p.dx - hx, p.dz + hz]]], np.float32)
            top = max(q.y1 for q in parts) + 0.05
            only_for(node.attachNewNode(meshes.flat_quads_node("footprint", quad, np.asarray([p.color], np.float32), top)), MAP_BIT)
        if o.is_trigger:
            node.setRenderModeWireframe()
            node.setLightOff(1)
        boards = [p for p in parts if p.label] or ([parts[-1]] if "sign" in key.lower() and len(parts) > 1 else [])
        for p in boards[:1]:
            from .sign_textures import face_texture

            tex = face_texture(p.label, p.color, p.hx / max(0.5 * (p.y1 - p.y0), 1e-3), key)
            board = meshes.textured_board_node("face", p.hx, p.y0, p.y1, p.hz, tex)
            board.reparentTo(node)
            board.setPos(p.dx, -p.dz, 0.0)
        return node

    def _custom_model(self, key: str, o: Any) -> Any:
        """The user's own model for this OpenDS key (exact key or glob), fitted to the object's box."""
        if not self.model_map or not key:
            return None
        path = self.model_map.get(key) or next((v for k, v in self.model_map.items() if fnmatch.fnmatch(key, k)), None)
        if path is None:
            return None
        p3d = panda()
        loader = p3d.Loader.getGlobalPtr()
        node = loader.loadSync(p3d.Filename.fromOsSpecific(path))
        if node is None:
            raise ValueError(f"model map: cannot load {path!r} for {key!r}")
        np_ = self.objects.attachNewNode("custom")
        np_.setLight(self.ambient, 2)
        np_.setLight(self.sun, 2)
        model = np_.attachNewNode(node)
        lo, hi = model.getTightBounds() or (p3d.LPoint3(0, 0, 0), p3d.LPoint3(1, 1, 1))
        size = hi - lo
        hx, hy, hz = o.half
        sx, sy, sz = (2 * hx / max(size[0], 1e-6), 2 * hz / max(size[1], 1e-6), 2 * hy / max(size[2], 1e-6))
        model.setScale(sx, sy, sz)
        model.setPos(-(lo[0] + hi[0]) * 0.5 * sx, -(lo[1] + hi[1]) * 0.5 * sy, -lo[2] * sz)
        return np_

    def _sync_traffic(self, ground_y: float, blink_on: bool) -> None:
        tr = self.world.traffic
        if tr is None or not len(getattr(tr, "ids", ())):
            return
        pos = tr.positions
        for i in range(len(tr.ids)):
            node = self._traffic.get(i)
            enabled = bool(tr.enabled[i]) and pos[i][1] > ground_y - BURIED_TRAFFIC_M
            if node is None:
                if not enabled:
                    continue
                hx, hz = (float(v) for v in tr.half_extents[i])
                if bool(tr.is_car[i]):
                    height = 1.45 if hz < 4.0 else 3.2
                    node = CarNode(self.objects, car_parts(hx, hz, height, pal.TRAFFIC_BODIES[i % len(pal.TRAFFIC_BODIES)]))
                else:
                    node = PedestrianNode(self.objects, i)
                self._traffic[i] = node
            if not enabled:
                node.hide()
                continue
            node.show()
            node.sync(
                float(pos[i][0]),
                float(pos[i][1]),
                float(pos[i][2]),
                float(tr.yaw[i]),
                bool(tr.brake_light[i]),
                int(tr.turn_signal[i]),
                blink_on,
            )


def object_parts(key: str, parts: tuple[Part, ...], o: Any) -> tuple[Part, ...]:
    """Our own low-poly looks for model kinds `styles.parts_for` draws as one box: trees and buildings."""
    k = key.lower()
    hx, hy, hz = o.half
    if "tree" in k:
        trunk = Part(0.0, 0.0, 0.0, 0.35 * 2 * hy, 0.12 * hx, 0.12 * hz, (100, 70, 40))
        crown = Part(0.0, 0.0, 0.3 * 2 * hy, 2 * hy, hx, hz, (45, 110, 45))
        return (trunk, crown)
    if "house" in k or "building" in k:
        walls = Part(0.0, 0.0, 0.0, 0.75 * 2 * hy, hx, hz, (205, 195, 175))
        roof = Part(0.0, 0.0, 0.75 * 2 * hy, 2 * hy, 1.05 * hx, 1.05 * hz, (150, 60, 45))
        return (walls, roof)
    return parts


class CarNode:
    """A car: body, cabin, wheels, headlights, brake lights and four turn signals."""

    def __init__(self, parent: Any, parts: tuple[Part, ...]) -> None:
        body = parts[0]
        hx, hz, height = body.hx, body.hz, parts[-1].y1
        wheel_r = 0.18 * height + 0.05
        wheels = tuple(
            Part(sx * (hx - 0.12), sz * 0.68 * hz, 0.0, 2 * wheel_r, 0.12, wheel_r, (25, 25, 25)) for sx in (-1, 1) for sz in (-1, 1)
        )
        self.np = parent.attachNewNode(meshes.boxes_node("car", (*parts, *wheels), bottom=True))
        lamp_y = 0.45 * height
        # brake and head lamps end 1 cm short of the turn signals at the corners: overlapping lamps in one
        # plane z-fought, and which one won changed with the order Panda3D happened to sort their states
        brake = [(s * (hx - 0.31), lamp_y, hz + 0.04, 0.0, 1.0, 0.18, 0.08) for s in (-1.0, 1.0)]
        head = [(s * (hx - 0.31), lamp_y, -hz - 0.04, 0.0, -1.0, 0.18, 0.08) for s in (-1.0, 1.0)]
        self.brake = self._lamps("brake", brake)
        self.head = self._lamps("head", head)
        self.head.setColor(_rgba((235, 235, 215)))
        self.signals = []
        for side in (-1.0, 1.0):
            pts = [(side * (hx - 0.06), lamp_y, end * (hz + 0.04), 0.0, end, 0.06, 0.06) for end in (1.0, -1.0)]
            self.signals.append(self._lamps("signal", pts))
        # the same lamps seen from above, for the map: flat patches on the roof's corners
        top = height + 0.05
        self.brake_map = self._map_lamps([(s * (hx - 0.3), top, hz - 0.15, 0.22, 0.15) for s in (-1.0, 1.0)])
        self.signals_map = [
            self._map_lamps([(side * (hx - 0.12), top, end * (hz - 0.12), 0.12, 0.12) for end in (1.0, -1.0)]) for side in (-1.0, 1.0)
        ]
        self._state: tuple[Any, ...] = ()
        self._lamp_state: tuple[Any, ...] = ()
        self._shown = True

    def _map_lamps(self, rows: Sequence[tuple[float, float, float, float, float]]) -> Any:
        quads = np.array([[[x - hw, z - hd], [x + hw, z - hd], [x + hw, z + hd], [x - hw, z + hd]] for x, _, z, hw, hd in rows], np.float32)
        node = self.np.attachNewNode(meshes.flat_quads_node("map-lamps", quads, np.full((len(rows), 3), 255.0, np.float32), rows[0][1]))
        node.setLightOff(1)
        node.setBin("fixed", 10)
        return only_for(node, MAP_BIT)

    def _lamps(self, name: str, rows: Sequence[tuple[float, ...]]) -> Any:
        node = self.np.attachNewNode(meshes.lamps_node(name, rows))
        node.setLightOff(1)
        return node

    def show(self) -> None:
        if not self._shown:
            self.np.show()
            self._shown = True

    def hide(self) -> None:
        if self._shown:
            self.np.hide()
            self._shown = False

    def sync(self, x: float, y: float, z: float, yaw: float, brake: bool, signal: int, blink_on: bool) -> None:
        pose = (x, y, z, yaw)
        if pose != self._state:
            self.np.setPosHpr(x, -z, y, math.degrees(yaw), 0.0, 0.0)
            self._state = pose
        lamps = (brake, signal if blink_on else 0)
        if lamps != self._lamp_state:
            brake_color = _rgba(pal.BRAKE_ON if brake else pal.BRAKE_OFF)
            self.brake.setColor(brake_color)
            self.brake_map.setColor(brake_color)
            for bit, node, flat in zip((1, 2), self.signals, self.signals_map):
                color = _rgba(pal.SIGNAL_ON if lamps[1] & bit else pal.SIGNAL_OFF)
                node.setColor(color)
                flat.setColor(color)
            self._lamp_state = lamps


class PedestrianNode(CarNode):
    """A person: legs, torso, arms and head (pedestrians have no lamps)."""

    CLOTHES = ((60, 70, 120), (120, 50, 50), (60, 100, 60), (90, 90, 90))

    def __init__(self, parent: Any, i: int) -> None:
        c = self.CLOTHES[i % len(self.CLOTHES)]
        parts = (
            Part(-0.1, 0.0, 0.0, 0.85, 0.08, 0.1, (40, 40, 55)),
            Part(0.1, 0.0, 0.0, 0.85, 0.08, 0.1, (40, 40, 55)),
            Part(0.0, 0.0, 0.85, 1.45, 0.2, 0.12, c),
            Part(-0.27, 0.0, 0.9, 1.42, 0.06, 0.07, c),
            Part(0.27, 0.0, 0.9, 1.42, 0.06, 0.07, c),
            Part(0.0, 0.0, 1.48, 1.72, 0.11, 0.11, (225, 185, 150)),
        )
        self.np = parent.attachNewNode(meshes.boxes_node("pedestrian", parts))
        self._state = ()
        self._shown = True

    def sync(self, x: float, y: float, z: float, yaw: float, brake: bool, signal: int, blink_on: bool) -> None:
        pose = (x, y, z, yaw)
        if pose != self._state:
            self.np.setPosHpr(x, -z, y, math.degrees(yaw), 0.0, 0.0)
            self._state = pose


class TrafficLightNode:
    """A pole and housing with red, yellow and green lamps on all four sides, lit by the light's phase."""

    def __init__(self, parent: Any, placement: Any) -> None:
        self.placement = placement
        top = LIGHT_POLE_M
        parts = (
            Part(0.0, 0.0, 0.0, top, 0.07, 0.07, pal.METAL),
            Part(0.0, 0.0, top, top + LIGHT_HOUSING_M, 0.2, 0.2, pal.LIGHT_HOUSING),
        )
        self.np = parent.attachNewNode(meshes.boxes_node("traffic-light", parts))
        self.np.setPosHpr(placement.x, -placement.z, placement.y, math.degrees(placement.yaw), 0.0, 0.0)
        self.lamps = []
        for j in range(3):
            y = top + LIGHT_HOUSING_M * (0.8 - 0.3 * j)
            rows = []
            for side in range(4):
                a = side * 0.5 * math.pi
                nx, nz = math.sin(a), math.cos(a)
                rows.append((0.25 * nx, y, 0.25 * nz, nx, nz, 0.12, 0.12))
            node = self.np.attachNewNode(meshes.lamps_node("lamp", rows))
            node.setLightOff(1)
            self.lamps.append(node)
        disc = meshes.disc_node("light-disc", [(LIGHT_DISC_M, (255, 255, 255))], segments=12)
        self.disc = only_for(self.np.attachNewNode(disc), MAP_BIT)
        self.disc.setZ(top + LIGHT_HOUSING_M + 0.05)
        self.disc.setLightOff(1)
        self._state = ""

    def sync(self, scene: WorldScene, world: Any) -> None:
        from .scene import light_state

        p = self.placement
        state = light_state(world, p.light_id, scene._initial.get(p.light_id, "off"))
        if state == self._state:
            return
        on = LAMPS_BY_STATE.get(state, (False, False, False))
        for lit, node, color in zip(on, self.lamps, (pal.LAMP_RED, pal.LAMP_YELLOW, pal.LAMP_GREEN)):
            node.setColor(_rgba(color if lit else pal.LAMP_DARK))
        self.disc.setColor(_rgba(MAP_LIGHT_COLORS.get(on, pal.LAMP_DARK)))
        self._state = state
