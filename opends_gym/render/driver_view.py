"""`DriverViewRenderer`: the 3D view from the driver's seat (or a chase or top camera) on Panda3D.

Why: perception research and human sessions need what the driver sees, on machines with
no display and no GPU. The World's scene graph (`stage.Stage`) is rendered offscreen by
Panda3D (`engine`); several cameras can share one frame as display regions (screens,
mirrors). Fog is applied from the depth buffer with OpenDS's visibility (`weather`), rain
and snow go on top. Camera modes follow OpenDS's `cameraMode`: ego (driver's eye), chase
(behind and above), static_back (further back), top (straight down, car pointing up),
outside (a fixed camera at the settings' `outsideCamPosition` that follows the car with its
gaze). The settings' `frustumNear`/`frustumFar` set the lens's clipping planes, and
`showHood` puts the bonnet in the driver's view.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from . import _pg, meshes
from . import shadows as shadows_
from .camera import OPENDS_FAR_M, OPENDS_VFOV_DEG, Camera
from .engine import Offscreen, panda
from .night import DARK_BELOW, darken, daylight
from .stage import CARD_BIT0, DEPTH_BIT, DETAIL_BIT, DETAIL_FOCAL_PX, INSIDE_BIT, ORDER_SKY, OUTSIDE_BIT, SUN_DIR, Stage
from .weather import Fog, Precipitation, fog_for, weather_of

CAMERA_MODES = ("ego", "chase", "static_back", "top", "outside")
OUTSIDE_OFFSET_M = (12.0, 4.0, 6.0)  # outside camera without `outsideCamPosition`: right, up, back of the start pose
# driver's eye relative to the car's reference point: behind it, left of centre, above the ground
EYE_BACK_M, EYE_LEFT_M, EYE_HEIGHT_M = 0.25, 0.35, 1.2
CHASE = {"chase": (7.0, 2.8, math.radians(-10.0)), "static_back": (12.0, 4.5, math.radians(-14.0))}
TOP_HEIGHT_M = 45.0
WIDE_ASPECT = 16.0 / 9.0
CARD_DIST_M = 100.0  # where a background card hangs in front of its camera (between near and far)
DEPTH_LEVELS = 4096  # the depth pass encodes eye depth in 12 bits over the far distance (red: high, green: low bits)
Viewport = tuple[float, float, float, float]  # left, right, bottom, top (fractions from the bottom-left)
FULL: Viewport = (0.0, 1.0, 0.0, 1.0)


@functools.lru_cache(maxsize=64)
def default_vfov_rad(width: int, height: int) -> float:
    """OpenDS's 30.5 degree vertical field of view on wide frames; narrower frames (an
    84x84 observation) keep the horizontal field of view of a 16:9 frame instead."""
    v = math.radians(OPENDS_VFOV_DEG)
    aspect = width / max(1, height)
    if aspect >= WIDE_ASPECT:
        return v
    h = 2.0 * math.atan(math.tan(0.5 * v) * WIDE_ASPECT)
    return 2.0 * math.atan(math.tan(0.5 * h) / aspect)


def pixel_rect(width: int, height: int, vp: Viewport) -> tuple[int, int, int, int]:
    """Pixel rect (x, y, w, h) of a viewport, as Panda3D rounds display regions."""
    left, right, bottom, top = vp
    x0, x1 = int(left * width + 0.5), int(right * width + 0.5)
    y1, y0 = height - int(bottom * height + 0.5), height - int(top * height + 0.5)
    return x0, y0, max(1, x1 - x0), max(1, y1 - y0)


class CameraSlot:
    """A Panda3D camera node and what was last set on it (lens, background card), so that an
    unchanged camera costs no Panda3D calls."""

    __slots__ = ("card", "card_bit", "card_exact", "card_key", "lens_key", "node")

    def __init__(self, node: Any, card_bit: int) -> None:
        self.node = node
        self.card_bit = card_bit  # the camera-mask bit its background card shows to
        self.card: Any = None
        self.card_key: tuple[Any, ...] = ()
        self.card_exact: tuple[Any, ...] = ()
        self.lens_key: tuple[Any, ...] = ()


class DriverViewRenderer:
    """3D view of a World. `render(w, h)` -> uint8 (h, w, 3); `render_views` for several cameras."""

    def __init__(
        self,
        world: Any,
        camera_mode: str = "ego",
        vfov_deg: float | None = None,
        show_triggers: bool = False,
        weather: bool = True,
        model_map: Any = None,
        shadows: str | None = None,
    ) -> None:
        if camera_mode not in CAMERA_MODES:
            raise ValueError(f"unknown camera mode {camera_mode!r}; choose from {', '.join(CAMERA_MODES)}")
        self.world = world
        self.camera_mode = camera_mode
        self.vfov_deg = vfov_deg
        self.weather = weather
        self.stage = Stage(world, show_triggers=show_triggers, model_map=model_map)
        settings = getattr(getattr(world, "task", None), "settings", None)
        self._general = getattr(settings, "general", None)
        self._near: float | None = getattr(self._general, "frustum_near_m", None)
        self._far: float | None = getattr(self._general, "frustum_far_m", None)
        self.show_hood = bool(getattr(self._general, "show_hood", False))
        self.scene = self.stage.scene
        # sun shadows on the ground (`shadows.py`): "auto" draws them where the pipe has shaders
        self.shadow_mode = shadows_.shadow_mode(shadows)
        self.shadows_active = shadows_.shadows_wanted(self.shadow_mode)
        self._shadow_map_drawn = False
        if self.shadows_active:
            shadows_.enable(self.stage, SUN_DIR)
        self.precipitation = Precipitation()
        self.daylight = daylight(world) if weather else 1.0  # the scene's lights (night.py): fixed per task
        self.headlights = True  # the ego's low beam (seen at night); the drive window's toggle_headlight
        self._target: Offscreen | None = None
        self._layout: tuple[Any, ...] = ()
        self._cams: list[CameraSlot] = []
        self._depth: Offscreen | None = None
        self._surface: Any = None

    # ------------------------------------------------------------------ cameras
    def camera(
        self,
        width: int,
        height: int,
        mode: str | None = None,
        yaw_offset: float = 0.0,
        pitch: float = 0.0,
        hfov_rad: float | None = None,
        mirror: bool = False,
        eye_offset: tuple[float, float, float] | None = None,
        vfov_rad: float | None = None,
    ) -> Camera:
        """A camera on the ego car: `mode` one of CAMERA_MODES; offsets for extra screens and mirrors.

        `eye_offset` is (right, up, back) metres from the car's reference point at ground level.
        """
        s = self.world.ego.state
        mode = mode or self.camera_mode
        vfov = vfov_rad or (math.radians(self.vfov_deg) if self.vfov_deg else default_vfov_rad(width, height))
        if mode == "outside" and eye_offset is None:
            x, y, z = self.outside_position()
            dx, dy, dz = s.x - x, s.y + 0.8 - y, s.z - z
            yaw, pitch = math.atan2(-dx, -dz), math.atan2(dy, math.hypot(dx, dz))
            return Camera(x, y, z, yaw, pitch, vfov, hfov_rad, self._near or 0.5, self._far or OPENDS_FAR_M, mirror=mirror)
        fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
        rx, rz = math.cos(s.yaw), -math.sin(s.yaw)
        if mode == "ego" or eye_offset is not None:
            right, up, back = eye_offset if eye_offset is not None else (-EYE_LEFT_M, EYE_HEIGHT_M, EYE_BACK_M)
            x, y, z = s.x + right * rx - back * fx, s.y + up, s.z + right * rz - back * fz
            return Camera(x, y, z, s.yaw + yaw_offset, pitch, vfov, hfov_rad, self._near or 0.3, self._far or OPENDS_FAR_M, mirror=mirror)
        if mode == "top":
            top = s.y + TOP_HEIGHT_M
            return Camera(s.x, top, s.z, s.yaw + yaw_offset, -0.5 * math.pi, vfov, hfov_rad, 1.0, self._far or OPENDS_FAR_M, mirror=mirror)
        back, up, tilt = CHASE[mode]
        x, y, z, yaw = s.x - back * fx, s.y + up, s.z - back * fz, s.yaw + yaw_offset
        return Camera(x, y, z, yaw, tilt + pitch, vfov, hfov_rad, self._near or 0.5, self._far or OPENDS_FAR_M, mirror=mirror)

    def outside_position(self) -> tuple[float, float, float]:
        """The outside camera's fixed place: `outsideCamPosition`, else beside the start pose."""
        pos = getattr(self._general, "outside_cam_position", None)
        if pos is not None and None not in (pos.x, pos.y, pos.z):
            return (float(pos.x), float(pos.y), float(pos.z))
        start = self.world.start_pose
        x, y, z = start.position_m
        yaw = start.yaw_rad
        right, up, back = OUTSIDE_OFFSET_M
        return (x + right * math.cos(yaw) + back * math.sin(yaw), y + up, z - right * math.sin(yaw) + back * math.cos(yaw))

    def inside_car(self, cam: Camera) -> bool:
        """True for a camera sitting in the ego car (the driver's eye, a mirror): the ego is not drawn for it."""
        s = self.world.ego.state
        return math.hypot(cam.x - s.x, cam.z - s.z) <= 2.5 and cam.y - s.y <= 3.0

    # ------------------------------------------------------------------ drawing
    def render(self, width: int, height: int) -> np.ndarray:
        weather = weather_of(self.world) if self.weather else {}
        frame = self.render_views(width, height, [(FULL, self.camera(width, height))], weather)
        if weather.get("raining_percent", -1.0) > 0 or weather.get("snowing_percent", -1.0) > 0:
            return self._precipitate(frame, [FULL], weather)
        return frame

    def render_surface(self, width: int, height: int) -> Any:
        """A frame on this renderer's own offscreen pygame surface (for overlays such as the HUD)."""
        frame = self.render(width, height)
        if self._surface is None or self._surface.get_size() != (width, height):
            self._surface = _pg.new_surface(width, height)
        _pg.pygame().surfarray.blit_array(self._surface, frame.swapaxes(0, 1))
        return self._surface

    def draw(self, surface: Any, cam: Camera) -> None:
        """Draw the world as seen by `cam` onto the whole of `surface`."""
        w, h = surface.get_size()
        weather = weather_of(self.world) if self.weather else {}
        frame = self._precipitate(self.render_views(w, h, [(FULL, cam)], weather), [FULL], weather)
        _pg.pygame().surfarray.blit_array(surface, frame.swapaxes(0, 1))

    def render_views(
        self, width: int, height: int, views: Sequence[tuple[Viewport, Camera]], weather: dict[str, float] | None = None
    ) -> np.ndarray:
        """One frame with each camera in its viewport (later viewports on top), fogged; no rain or snow."""
        target = self._draw_views(width, height, views)
        frame = target.rgb()
        if weather is None:
            weather = weather_of(self.world) if self.weather else {}
        fog = fog_for(weather)
        night = self.daylight < DARK_BELOW
        if fog is not None or night:
            depth = self._depth_pass(width, height, views)
            if fog is not None:
                self._fog(frame, depth, views, fog)
            if night:
                for vp, cam in views:
                    x, y, w, h = pixel_rect(width, height, vp)
                    beam = self.headlights and self.inside_car(cam) and not cam.mirror
                    darken(frame[y : y + h, x : x + w], depth[y : y + h, x : x + w], self.daylight, beam, cam.focal_px(w, h))
        return frame

    def blit_views(self, surface: Any, views: Sequence[tuple[Viewport, Camera]]) -> None:
        """`render_views` onto a pygame surface; without fog the frame goes there straight from
        Panda3D's buffer (no numpy copy: what keeps a 1280x720 window fast)."""
        pg = _pg.pygame()
        w, h = surface.get_size()
        if self.daylight < DARK_BELOW or (self.weather and fog_for(weather_of(self.world)) is not None):
            surface.blit(_pg.from_array(self.render_views(w, h, views)), (0, 0))
            return
        target = self._draw_views(w, h, views)
        fmt = {4: "BGRA", 3: "BGR"}[target.components()]
        img = pg.image.frombuffer(target.bgra_bytes(), (w, h), fmt)
        surface.blit(pg.transform.flip(img, False, True), (0, 0))

    def _draw_views(self, width: int, height: int, views: Sequence[tuple[Viewport, Camera]]) -> Offscreen:
        target = self._prepare(width, height, views)
        main = views[0][1]
        inside = [self.inside_car(c) for _, c in views]
        self.stage.sync(main.x, main.y, main.z, include_ego=not all(inside))
        if self.shadows_active:
            shadows_.follow(self.stage, main.x, self.world.ego.state.y, main.z, SUN_DIR)
            if not self._shadow_map_drawn:  # Panda3D makes the shadow buffer during the first frame and fills it from the next
                target.render()
                self._shadow_map_drawn = True
        for k, (slot, (vp, cam)) in enumerate(zip(self._cams, views)):
            w, h = (width, height) if vp is FULL else pixel_rect(width, height, vp)[2:]
            self._place(slot, cam, w, h, inside[k])
        target.render()
        return target

    def _prepare(self, width: int, height: int, views: Sequence[tuple[Viewport, Camera]]) -> Offscreen:
        layout = (width, height, tuple(vp for vp, _ in views))
        if self._target is not None and self._layout == layout:
            return self._target
        if self._target is None or (self._target.width, self._target.height) != (width, height):
            if self._target is not None:
                self._target.close()
            self._target = Offscreen(width, height)
        else:
            self._target.buffer.removeAllDisplayRegions()
        for slot in self._cams:
            slot.node.removeNode()
        self._cams = []
        if self._depth is not None:
            self._depth.close()
            self._depth = None
        for k, (vp, _) in enumerate(views):
            slot = self.new_slot(f"cam{k}", CARD_BIT0 + k)
            self._target.region(*vp, camera=slot.node, sort=k)
            self._cams.append(slot)
        self._layout = layout
        return self._target

    def new_slot(self, name: str, card_bit: int) -> CameraSlot:
        """A camera under this renderer's stage (for a display region of any buffer) whose
        background card shows to cameras with `card_bit` only."""
        p3d = panda()
        cam_node = p3d.Camera(name)
        cam_node.setLens(p3d.PerspectiveLens())
        self.stage.show_hood = self.show_hood
        if self.show_hood:
            self.stage.hood.show(p3d.BitMask32.bit(INSIDE_BIT))
        return CameraSlot(self.stage.root.attachNewNode(cam_node), card_bit)

    def needs_post(self) -> bool:
        """Whether a frame of this view is more than one colour pass: fog or night (a depth
        pass), rain or snow (drawn over the frame), or shadows (a shadow map)."""
        if self.shadows_active or self.daylight < DARK_BELOW:
            return True
        if not self.weather:
            return False
        weather = weather_of(self.world)
        return fog_for(weather) is not None or weather.get("raining_percent", -1.0) > 0 or weather.get("snowing_percent", -1.0) > 0

    def stage_view(self, slot: CameraSlot, width: int, height: int) -> None:
        """Sync the stage and aim `slot` as `render(width, height)` would, without drawing: for
        a caller that draws many renderers' slots in one frame (`batch_view`)."""
        cam = self.camera(width, height)
        inside = self.inside_car(cam)
        self.stage.sync(cam.x, cam.y, cam.z, include_ego=not inside)
        self._place(slot, cam, width, height, inside)

    def _place(self, slot: CameraSlot, cam: Camera, w: int, h: int, inside: bool) -> None:
        node = slot.node
        focal = cam.focal_px(w, h)
        lens_key = (w, h, focal, cam.near, cam.far, inside, cam.mirror)
        if lens_key != slot.lens_key:  # (a lens change makes Panda3D recompute its matrices: only when needed)
            p3d = panda()
            lens = node.node().getLens()
            lens.setFilmSize(w, h)
            lens.setFocalLength(focal)
            lens.setNearFar(cam.near, cam.far)
            mask = p3d.BitMask32.bit(INSIDE_BIT if inside else OUTSIDE_BIT) | p3d.BitMask32.bit(slot.card_bit)
            if focal >= DETAIL_FOCAL_PX:
                mask |= p3d.BitMask32.bit(DETAIL_BIT)
            node.node().setCameraMask(mask)
            slot.lens_key = lens_key
        node.setPosHprScale(
            cam.x, -cam.z, cam.y, math.degrees(cam.yaw), math.degrees(cam.pitch), 0.0, -1.0 if cam.mirror else 1.0, 1.0, 1.0
        )
        eye_height = max(cam.y - self.world.ego.state.y, 0.05)
        exact = (w, h, focal, cam.pitch, eye_height)
        if exact == slot.card_exact:
            return  # (the usual frame: the same lens, pitch and eye height, nothing to round)
        slot.card_exact = exact
        key = (w, h, round(focal, 3), round(cam.pitch, 4), round(eye_height, 3))
        if key != slot.card_key:  # the sky-and-grass card: rebuilt only when the lens, pitch or eye height change
            p3d = panda()
            if slot.card is not None:
                slot.card.removeNode()
            card = node.attachNewNode(meshes.background_node("background", w, h, focal, cam.pitch, eye_height, CARD_DIST_M))
            card.setBin("background", ORDER_SKY)
            card.setDepthTest(False)
            card.setDepthWrite(False)
            card.setLightOff(1)
            card.hide(p3d.BitMask32.allOn())
            card.show(p3d.BitMask32.bit(slot.card_bit))
            slot.card = card
            slot.card_key = key

    def _depth_pass(self, width: int, height: int, views: Sequence[tuple[Viewport, Camera]]) -> np.ndarray:
        """Eye depth in metres per pixel (inf where the sky is): the scene drawn again with each
        surface coloured by its distance (a texture looked up by the eye-space position), which
        works on every pipe (the software renderer cannot read its depth buffer back)."""
        p3d = panda()
        if self._depth is None:
            self._depth = Offscreen(width, height, clear=(1.0, 1.0, 0.0))
            self._depth_cams: list[Any] = []
            ramp = p3d.Texture("depth-ramp")
            i = np.arange(DEPTH_LEVELS)
            rgb = np.stack([i // 16, (i % 16) * 16, np.zeros_like(i)], axis=1).astype(np.uint8)
            ramp.setup2dTexture(DEPTH_LEVELS, 1, p3d.Texture.TUnsignedByte, p3d.Texture.FRgb)
            ramp.setRamImageAs(rgb.tobytes(), "RGB")
            ramp.setMinfilter(p3d.SamplerState.FTNearest)
            ramp.setMagfilter(p3d.SamplerState.FTNearest)
            ramp.setWrapU(p3d.SamplerState.WMClamp)
            self._ramp = ramp
            for k, ((vp, _), slot) in enumerate(zip(views, self._cams)):
                colour_cam = slot.node
                node = colour_cam.attachNewNode(p3d.Camera(f"depth{k}", colour_cam.node().getLens()))
                self._depth.region(*vp, camera=node, sort=k)
                self._depth_cams.append(node)
        ts = p3d.TextureStage.getDefault()
        for (_, cam), slot, node in zip(views, self._cams, self._depth_cams):
            colour_cam = slot.node
            m = p3d.Mat4(0, 0, 0, 0, 1.0 / cam.far, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1)
            state = p3d.RenderState.make(
                p3d.TextureAttrib.make(self._ramp),
                p3d.TexGenAttrib.make(ts, p3d.TexGenAttrib.MEyePosition),
                p3d.TexMatrixAttrib.make(ts, p3d.TransformState.makeMat(m)),
                p3d.ColorAttrib.makeFlat((1, 1, 1, 1)),
                p3d.LightAttrib.makeAllOff(),
                10000,
            )
            if self.shadows_active:  # (the depth colours come from the fixed-function texture lookup)
                state = state.addAttrib(p3d.ShaderAttrib.makeOff(), 10000)
            node.node().setInitialState(state)
            inside = colour_cam.node().getCameraMask() & p3d.BitMask32.bit(INSIDE_BIT)
            bits = p3d.BitMask32.bit(DEPTH_BIT) | (inside if inside.getWord() else p3d.BitMask32.bit(OUTSIDE_BIT))
            node.node().setCameraMask(bits)
        self.stage.place_grass()
        self._depth.render()
        rgb = self._depth.rgb().astype(np.int64)
        level: np.ndarray = rgb[..., 0] * 16 + rgb[..., 1] // 16
        depth = np.empty(level.shape)
        for vp, cam in views:
            x, y, w, h = pixel_rect(width, height, vp)
            depth[y : y + h, x : x + w] = (level[y : y + h, x : x + w] + 0.5) * (cam.far / DEPTH_LEVELS)
        depth[level >= DEPTH_LEVELS - 1] = np.inf
        return depth

    @staticmethod
    def _fog(frame: np.ndarray, depth: np.ndarray, views: Sequence[tuple[Viewport, Camera]], fog: Fog) -> None:
        """Blend each pixel towards the fog colour by its depth (Koschmieder, as `weather` says)."""
        amount = fog.amount(np.where(np.isinf(depth), 1e5, depth))[..., None]
        blended = frame.astype(np.float64) * (1 - amount) + np.asarray(fog.color, float) * amount
        frame[:] = np.clip(blended + 0.5, 0, 255).astype(np.uint8)

    def _precipitate(self, frame: np.ndarray, viewports: Sequence[Viewport], weather: dict[str, float]) -> np.ndarray:
        if not any(weather.get(k, -1.0) > 0 for k in ("raining_percent", "snowing_percent")):
            return frame
        surface = _pg.from_array(frame).copy()
        self.precipitate_on(surface, viewports)
        return _pg.to_array(surface)

    def precipitate_on(self, surface: Any, viewports: Sequence[Viewport]) -> None:
        """Rain streaks and snow flakes (screen space, simulation time) over each viewport."""
        weather = weather_of(self.world) if self.weather else {}
        if not any(weather.get(k, -1.0) > 0 for k in ("raining_percent", "snowing_percent")):
            return
        w, h = surface.get_size()
        for vp in viewports:
            self.precipitation.draw(surface.subsurface(pixel_rect(w, h, vp)), weather, self.world.t_s)
