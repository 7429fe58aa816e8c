"""scenario.xml `road`: lanes, traffic lights, signs, speed limits and the segment network.

Why: lanes (bands of world X) drive the reaction timers; intersections hold the traffic
lights traffic obeys; Gen B waypoints and segments are the road network traffic roams.
"""

from __future__ import annotations

from dataclasses import dataclass

from lxml import etree

from .bind import (
    BOOL,
    FLOAT,
    INT,
    KMH,
    MS,
    STR,
    TEXT_ITEM,
    Choice,
    Custom,
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
from .model_traffic import TURN_SIGNALS
from .values import VEC3, Vec3


@dataclass(frozen=True)
class Lane:
    """A lane as OpenDS's reaction timers see it: the band xMin <= X <= xMax (metres)."""

    id: str = attr("id", required=True)
    x_min_m: float = elem("xMin", FLOAT, required=True)
    x_max_m: float = elem("xMax", FLOAT, required=True)
    line: int = source_line()

    @property
    def center_m(self) -> float:
        return 0.5 * (self.x_min_m + self.x_max_m)

    @property
    def width_m(self) -> float:
        return self.x_max_m - self.x_min_m


TRAFFIC_LIGHT_MODES = ("trigger", "program", "external", "blinking", "off")
LIGHT_STATES = ("red", "yellow", "green", "all", "off", "yellowred")
LIGHT_DIRECTIONS = ("up", "left", "right", "none")


@dataclass(frozen=True)
class Phase:
    """One step of a light program: a SUMO-style state string, one character per light."""

    id: str = attr("id", STR, "")
    duration_s: float = attr("duration", MS, 0.0)
    state: str = attr("state", STR, "")
    line: int = source_line()


@dataclass(frozen=True)
class PositionData:
    road_id: str | None = attr("roadID", STR)
    crossing_type: int | None = attr("crossingType", INT)
    arrow_type: int | None = attr("arrowType", INT)
    lane: int | None = attr("lane", INT)


@dataclass(frozen=True)
class TrafficLightSpec:
    id: str = attr("id", required=True)
    ref: str = attr("ref", STR, "")
    phase_position: int | None = attr("phasePosition", INT)
    trigger: str = attr("trigger", STR, "")
    phase_trigger: str = attr("phaseTrigger", STR, "")
    initial_state: str = elem("initialState", Choice(*LIGHT_STATES), "red")
    direction: str | None = elem("direction", Choice(*LIGHT_DIRECTIONS))
    requires_red: str | None = elem("requiresRed", STR)
    position_data: PositionData | None = elem("positionData", Struct(PositionData))
    affected_lane: int | None = elem("affectedLane", INT)
    line: int = source_line()


@dataclass(frozen=True)
class Intersection:
    id: str = attr("id", required=True)
    mode: str = attr("mode", Choice(*TRAFFIC_LIGHT_MODES), "trigger")
    phases: tuple[Phase, ...] = elems("phases", ("phase", Struct(Phase)))
    traffic_lights: tuple[TrafficLightSpec, ...] = elems("trafficLights", ("trafficLight", Struct(TrafficLightSpec)))
    line: int = source_line()


@dataclass(frozen=True)
class RoadSign:
    """Gen A: a road sign model reference (`ref` = scene model id)."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    line: int = source_line()


@dataclass(frozen=True)
class SpeedLimit:
    """Gen A: a speed limit attached to a scene model (`ref`); limit 0 = none."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    profile: str | None = attr("profile", STR)
    ending: bool = elem("ending", BOOL, False)
    limit_mps: float | None = elem("limit", KMH)
    line: int = source_line()


@dataclass(frozen=True)
class RoadWayPoint:
    """Gen B: a node of the road network (inline position or `ref` to a scene point)."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    translation_m: Vec3 | None = elem("translation", VEC3)
    traffic_light: str | None = elem("trafficLight", STR)
    head_light_intensity: float | None = elem("headLightIntensity", FLOAT)
    turn_signal: str | None = elem("turnSignal", Choice(*TURN_SIGNALS))
    brake_light_on: bool | None = elem("brakeLightOn", BOOL)
    waiting_time_s: float | None = elem("waitingTime", MS)
    line: int = source_line()

    @property
    def key(self) -> str:
        """The id other elements use for this waypoint (its own id, else its ref)."""
        return self.id or self.ref


@dataclass(frozen=True)
class RoadWayPoints:
    debug: bool | None = attr("debug", BOOL)
    align_to_terrain: bool | None = attr("alignToTerrain", BOOL)
    points: tuple[RoadWayPoint, ...] = elems(".", ("wayPoint", Struct(RoadWayPoint)))


@dataclass(frozen=True)
class Segment:
    """Gen B: a directed road piece from one waypoint (via others) to another."""

    id: str = attr("id", required=True)
    from_wp: str = elem("from", STR, required=True)
    via: tuple[str, ...] = elems("via", ("wp", TEXT_ITEM))
    to_wp: str = elem("to", STR, required=True)
    left_neighbor: str | None = elem("leftNeighbor", STR)
    right_neighbor: str | None = elem("rightNeighbor", STR)
    speed_mps: float = elem("speed", KMH, 50.0 / 3.6)
    jump: bool = elem("jump", BOOL, False)
    probability: float = elem("probability", FLOAT, 1.0)
    give_way_to: str | None = elem("giveWayTo", STR)
    curve_tension: float | None = elem("curveTension", FLOAT)
    line: int = source_line()


@dataclass(frozen=True)
class Segments:
    is_right_hand_traffic: bool | None = attr("isRightHandTraffic", BOOL)
    debug: bool | None = attr("debug", BOOL)
    items: tuple[Segment, ...] = elems(".", ("segment", Struct(Segment)))


@dataclass(frozen=True)
class Road:
    lanes: tuple[Lane, ...] = elems(".", ("lane", Struct(Lane)))
    intersections: tuple[Intersection, ...] = elems(".", ("intersection", Struct(Intersection)))
    road_signs: tuple[RoadSign, ...] = elems(".", ("roadsign", Struct(RoadSign)))
    speed_limits: tuple[SpeedLimit, ...] = elems(".", ("speedLimit", Struct(SpeedLimit)))
    way_points: RoadWayPoints | None = elem("wayPoints", Struct(RoadWayPoints))
    segments: Segments | None = elem("segments", Struct(Segments))

    def lane(self, lane_id: str) -> Lane | None:
        return next((lane for lane in self.lanes if lane.id == lane_id), None)


@dataclass(frozen=True)
class FrictionItem:
    geometry: str = attr("geometry", STR, "")
    value: float = attr("value", FLOAT, 1.0)
    line: int = source_line()


MATRIX_KEYS = tuple(f"m{r}{c}" for r in range(4) for c in range(4))


def _read_matrix(el: etree._Element, ctx: ReadCtx) -> tuple[float, ...]:
    holder = children(el, "matrix")
    if not holder:
        raise ctx.error(f"<{el.tag}> needs a <matrix>", el)
    values = []
    for key in MATRIX_KEYS:
        node = children(holder[0], key)
        if not node:
            raise ctx.error(f"missing required element <{key}>", holder[0], "matrix")
        values.append(parse_scalar(FLOAT, node[0].text or "", node[0], ctx))
    return tuple(values)


def _write_matrix(el: etree._Element, value: tuple[float, ...], ctx: WriteCtx) -> None:
    m = ctx.sub(el, "matrix")
    for key, v in zip(MATRIX_KEYS, value):
        ctx.sub(m, key).text = repr(float(v))


MATRIX = Custom(_read_matrix, _write_matrix)


@dataclass(frozen=True)
class CoordinateConversion:
    """4x4 row-major matrices between model (world) and geo coordinates."""

    model_to_geo: tuple[float, ...] | None = elem("modelToGeo", MATRIX)
    geo_to_model: tuple[float, ...] | None = elem("geoToModel", MATRIX)
