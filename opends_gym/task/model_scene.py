"""scene.xml: sounds, movies, pictures, models, geometries, reset points, lights.

Why: the scene is where every object of a driving task lives, trigger volumes included
(they are ordinary models named by `collideWith` conditions).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from lxml import etree

from .bind import (
    BOOL,
    FLOAT,
    INT,
    RAW,
    STR,
    Choice,
    Custom,
    Node,
    RawElement,
    ReadCtx,
    Struct,
    WriteCtx,
    attr,
    children,
    elem,
    elems,
    parse_scalar,
    source_line,
)
from .values import COLOR, FLOATS, ROTATION, VEC3, Rotation, Vec3
from .xmlsafe import local_name


@dataclass(frozen=True)
class SoundParentNode:
    """Scene-graph node a positional sound is attached to (one of the four)."""

    root_node: str | None = elem("rootNode", STR)
    model_node: str | None = elem("modelNode", STR)
    traffic_node: str | None = elem("trafficNode", STR)
    driver_node: str | None = elem("driverNode", STR)


@dataclass(frozen=True)
class PositionalAudio:
    enabled: bool = attr("value", BOOL, False, keep=True)
    parent_node: SoundParentNode | None = elem("parentNode", Struct(SoundParentNode))
    translation_m: Vec3 | None = elem("translation", VEC3)
    ref_distance_m: float | None = elem("refDistance", FLOAT)
    max_distance_m: float | None = elem("maxDistance", FLOAT)
    reverb: bool | None = elem("reverb", BOOL)


@dataclass(frozen=True)
class DirectionalAudio:
    enabled: bool = attr("value", BOOL, False)
    direction: Vec3 | None = elem("direction", VEC3)
    inner_angle_deg: float | None = elem("innerAngle", FLOAT)
    outer_angle_deg: float | None = elem("outerAngle", FLOAT)


@dataclass(frozen=True)
class Sound:
    id: str = attr("id", required=True)
    key: str = attr("key", STR, "")
    positional: PositionalAudio | None = elem("positional", Struct(PositionalAudio))
    directional: DirectionalAudio | None = elem("directional", Struct(DirectionalAudio))
    loop: bool = elem("loop", BOOL, False)
    volume: float = elem("volume", FLOAT, 1.0)
    pitch: float = elem("pitch", FLOAT, 1.0)
    polly_text: str | None = elem("fromAmazonPolly/text", STR)
    line: int = source_line()


@dataclass(frozen=True)
class Movie:
    id: str = attr("id", required=True)
    key: str = attr("key", STR, "")
    width_px: int | None = elem("width", INT)
    height_px: int | None = elem("height", INT)
    zooming_factor: float | None = elem("zoomingFactor", FLOAT)
    line: int = source_line()


@dataclass(frozen=True)
class ScreenAnchor:
    """A picture's offset from a screen edge: edge is fromTop/fromBottom/fromLeft/fromRight/center."""

    edge: str = "center"
    unit: str = ""
    value: int = 0


def _read_anchor(el: etree._Element, ctx: ReadCtx) -> ScreenAnchor:
    kids = children(el)
    if not kids:
        raise ctx.error(f"<{local_name(el)}> needs one of fromTop/fromBottom/fromLeft/fromRight/center", el)
    c = kids[0]
    edge = local_name(c)
    if edge not in ("fromTop", "fromBottom", "fromLeft", "fromRight", "center"):
        raise ctx.error(f"unknown position <{edge}>", c)
    value = c.get("value")
    return ScreenAnchor(edge, (c.get("unit") or "").strip(), parse_scalar(INT, value, c, ctx, "attribute 'value'") if value else 0)


def _write_anchor(el: etree._Element, v: ScreenAnchor, ctx: WriteCtx) -> None:
    c = ctx.sub(el, v.edge)
    if v.edge != "center":
        c.set("unit", v.unit)
        c.set("value", str(v.value))


ANCHOR = Custom(_read_anchor, _write_anchor)


@dataclass(frozen=True)
class Picture:
    """A HUD image, shown and hidden by `manipulatePicture`."""

    id: str = attr("id", required=True)
    key: str = attr("key", STR, "")
    level: int = attr("level", INT, 0)
    v_position: ScreenAnchor = elem("vPosition", ANCHOR, ScreenAnchor(), keep=True)
    h_position: ScreenAnchor = elem("hPosition", ANCHOR, ScreenAnchor(), keep=True)
    width_px: int | None = elem("width", INT)
    height_px: int | None = elem("height", INT)
    use_alpha: bool = elem("useAlpha", BOOL, False)
    visible: bool = elem("visible", BOOL, False)
    line: int = source_line()


@dataclass(frozen=True)
class Material:
    key: str | None = attr("key", STR)
    color_rgba: tuple[float, ...] | None = elem("color", COLOR)


@dataclass(frozen=True)
class OpenDrivePosition:
    """2023: a model placed by OpenDRIVE road coordinates instead of a translation."""

    road_id: str = attr("roadID", required=True)
    s_m: float = attr("s", FLOAT, 0.0)
    lateral_offset_m: float = attr("lateralOffset", FLOAT, 0.0)
    vertical_offset_m: float = attr("verticalOffset", FLOAT, 0.0)


COLLISION_SHAPES = ("none", "boxShape", "meshShape")
SHADOW_MODES = ("CastAndReceive", "Cast", "Receive", "Off")


@dataclass(frozen=True)
class Model:
    """A scene object: an asset (`key`) or a geometry (`ref`); trigger volumes are models too."""

    id: str = attr("id", STR, "")
    key: str = attr("key", STR, "")
    ref: str = attr("ref", STR, "")
    mass_kg: float = elem("mass", FLOAT, 0.0)
    material: Material | None = elem("material", Struct(Material))
    visible: bool = elem("visible", BOOL, True)
    add_to_map_node: bool | None = elem("addToMapNode", BOOL)
    collision_shape: str = elem("collisionShape", Choice(*COLLISION_SHAPES), "meshShape", keep=True)
    collision_sound_ref: str | None = elem("collisionSound/@ref", STR)
    texture_scale: tuple[float, ...] | None = elem("textureScale", FLOATS)
    scale: Vec3 = elem("scale", VEC3, (1.0, 1.0, 1.0))
    rotation: Rotation = elem("rotation", ROTATION, Rotation(), keep=True)
    translation_m: Vec3 | None = elem("translation", VEC3)
    open_drive_position: OpenDrivePosition | None = elem("openDrivePosition", Struct(OpenDrivePosition))
    ambient_light_rgba: tuple[float, ...] | None = elem("ambientLight/color", COLOR)
    shadow_mode: str | None = elem("shadowMode", Choice(*SHADOW_MODES))
    reference_object: RawElement | None = elem("referenceObject", RAW)
    line: int = source_line()

    @property
    def is_static(self) -> bool:
        return self.mass_kg <= 0.0


@dataclass(frozen=True)
class Box:
    id: str = attr("id", required=True)
    width_m: float = elem("width", FLOAT, required=True)
    depth_m: float = elem("depth", FLOAT, required=True)
    height_m: float = elem("height", FLOAT, required=True)
    line: int = source_line()


@dataclass(frozen=True)
class Sphere:
    id: str = attr("id", required=True)
    samples_axis: int = elem("samples/@axis", INT, 16)
    samples_radial: int = elem("samples/@radial", INT, 16)
    radius_m: float = elem("radius", FLOAT, required=True)
    line: int = source_line()


@dataclass(frozen=True)
class Cylinder:
    id: str = attr("id", required=True)
    samples_axis: int = elem("samples/@axis", INT, 16)
    samples_radial: int = elem("samples/@radial", INT, 16)
    radius_m: float = elem("radius", FLOAT, required=True)
    height_m: float = elem("height", FLOAT, required=True)
    closed: bool = elem("closed", BOOL, True, keep=True)
    line: int = source_line()


@dataclass(frozen=True)
class Terrain:
    """A height-map terrain; the image asset may be missing (then the ground is flat)."""

    id: str = attr("id", required=True)
    height_map_key: str = elem("imageBasedHeightMap/@key", STR, "")
    height_scale: float = elem("imageBasedHeightMap/@heightScale", FLOAT, 1.0)
    smoothing_percentage: float | None = elem("smoothing/@percentage", FLOAT)
    smoothing_radius: int | None = elem("smoothing/@radius", INT)
    lod_patch_size: int | None = elem("lod/@patchSize", INT)
    lod_total_size: int | None = elem("lod/@totalSize", INT)
    lod_distance_factor: float | None = elem("lod/@distanceFactor", FLOAT)
    line: int = source_line()


@dataclass(frozen=True)
class Point:
    """A named position, referenced by ideal tracks, camera flights and waypoints."""

    id: str = attr("id", required=True)
    translation_m: Vec3 = elem("translation", VEC3, required=True)
    line: int = source_line()


Geometry = Box | Sphere | Cylinder | Terrain | Point

GEOMETRY_ITEMS: dict[str, Node[Any]] = {
    "box": Struct(Box),
    "sphere": Struct(Sphere),
    "cylinder": Struct(Cylinder),
    "terrain": Struct(Terrain),
    "point": Struct(Point),
}


@dataclass(frozen=True)
class ResetPoint:
    id: str = attr("id", required=True)
    translation_m: Vec3 = elem("translation", VEC3, required=True)
    rotation: Rotation = elem("rotation", ROTATION, Rotation(), keep=True)
    line: int = source_line()


@dataclass(frozen=True)
class DirectionalLight:
    direction: Vec3 = elem("direction", VEC3, required=True)
    color_rgba: tuple[float, ...] | None = elem("color", COLOR)


@dataclass(frozen=True)
class PointLight:
    position_m: Vec3 = elem("position", VEC3, required=True)
    radius_m: float | None = elem("radius", FLOAT)
    color_rgba: tuple[float, ...] | None = elem("color", COLOR)


@dataclass(frozen=True)
class AmbientLight:
    color_rgba: tuple[float, ...] = elem("color", COLOR, required=True)


Light = DirectionalLight | PointLight | AmbientLight


@dataclass(frozen=True)
class Scene:
    sounds: tuple[Sound, ...] = elems("sounds", ("sound", Struct(Sound)))
    movies: tuple[Movie, ...] = elems("movies", ("movie", Struct(Movie)))
    pictures: tuple[Picture, ...] = elems("pictures", ("picture", Struct(Picture)))
    models: tuple[Model, ...] = elems("models", ("model", Struct(Model)))
    geometries: tuple[Geometry, ...] = elems("geometries", GEOMETRY_ITEMS)
    vegetation: RawElement | None = elem("vegetation", RAW)
    reset_points: tuple[ResetPoint, ...] = elems("resetPoints", ("resetPoint", Struct(ResetPoint)))
    gravity_mps2: float = elem("gravity", FLOAT, 9.81)
    time: str | None = elem("time", STR)
    date: str | None = elem("date", STR)
    lights: tuple[Light, ...] = elems(
        "lights",
        {
            "directionalLight": Struct(DirectionalLight),
            "pointLight": Struct(PointLight),
            "ambientLight": Struct(AmbientLight),
        },
    )
    sky_texture: str | None = elem("skyTexture", STR)

    def model(self, model_id: str) -> Model | None:
        """The first model with this id (ids of scenery tiles may repeat)."""
        return next((m for m in self.models if m.id == model_id), None)

    def geometry(self, geometry_id: str) -> Geometry | None:
        return next((g for g in self.geometries if g.id == geometry_id), None)

    def reset_point(self, reset_id: str) -> ResetPoint | None:
        return next((r for r in self.reset_points if r.id == reset_id), None)
