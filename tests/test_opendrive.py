"""OpenDRIVE roads: geometry, lanes, locate, routes, start pose and openDrivePos triggers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from opends_gym.sim.controls import DriverControls
from opends_gym.sim.opendrive.map import OpenDriveError, OpenDriveMap
from opends_gym.sim.world import World, WorldConfig
from opends_gym.task import load_task
from opends_gym.task.model_traffic import ODConnection

from .conftest import CORPUS

INIT_DRIVE = "opends2023-annegretj/init_drive"

WIDTH_35 = '<width sOffset="0" a="3.5" b="0" c="0" d="0"/>'
LEFT_1 = f'<left><lane id="1" type="driving"><link><predecessor id="1"/><successor id="1"/></link>{WIDTH_35}</lane></left>'
RIGHT_1 = f'<right><lane id="-1" type="driving"><link><predecessor id="-1"/><successor id="-1"/></link>{WIDTH_35}</lane></right>'
CENTER = '<center><lane id="0" type="driving"/></center>'
LANES_2 = f'<lanes><laneSection s="0">{LEFT_1}{CENTER}{RIGHT_1}</laneSection></lanes>'


def road(rid: str, length: float, geometry: str, lanes: str = LANES_2, link: str = "", junction: str = "-1") -> str:
    return (
        f'<road name="{rid}" id="{rid}" length="{length}" junction="{junction}"><link>{link}</link>'
        f"<planView>{geometry}</planView>{lanes}</road>"
    )


def geom(x: float, y: float, hdg: float, length: float, shape: str, s: float = 0.0) -> str:
    return f'<geometry s="{s}" x="{x}" y="{y}" hdg="{hdg}" length="{length}">{shape}</geometry>'


def write_map(tmp_path: Path, body: str, name: str = "map.xodr") -> OpenDriveMap:
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<OpenDRIVE>\n<header revMajor="1" revMinor="5"/>\n{body}\n</OpenDRIVE>\n', encoding="utf-8")
    return OpenDriveMap.load(path)


def menger_curvature(p: np.ndarray) -> np.ndarray:
    """Signed curvature through consecutive point triples (positive turning left in OpenDRIVE)."""
    a, b, c = p[:-2], p[1:-1], p[2:]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    la, lb, lc = (np.linalg.norm(u, axis=1) for u in (b - a, c - b, c - a))
    return 2.0 * cross / (la * lb * lc)


def od_xy(m: OpenDriveMap, rid: str, s: np.ndarray) -> np.ndarray:
    """Reference-line points in OpenDRIVE coordinates (world x, -world z)."""
    pts = np.array([m.position_to_world(rid, float(v), 0.0)[:2] for v in s])
    return np.column_stack([pts[:, 0], -pts[:, 1]])


# ---------------------------------------------------------------------- geometry
def test_straight_road_world_mapping_lane_centres_and_locate(tmp_path: Path) -> None:
    m = write_map(tmp_path, road("r", 100, geom(10, 20, 0.0, 100, "<line/>")))
    # OpenDRIVE (x, y) -> world (x, -y); the road runs east = world +X, yaw -pi/2
    x, z, yaw = m.lane_center("r", -1, 30.0)
    assert (x, z) == pytest.approx((40.0, -18.25)) and yaw == pytest.approx(-math.pi / 2)
    x, z, yaw = m.lane_center("r", 1, 30.0)  # left lanes drive towards decreasing s
    assert (x, z) == pytest.approx((40.0, -21.75)) and yaw == pytest.approx(math.pi / 2)
    # openDrivePosition as OpenDS's MapObjectOD: positive lateral offset to the right of +s
    assert m.position_to_world("r", 30.0, 2.0) == pytest.approx((40.0, -18.0, -math.pi / 2))
    assert m.locate(40.0, -18.25) == ("r", -1, pytest.approx(30.0))
    assert m.locate(40.0, -21.75) == ("r", 1, pytest.approx(30.0))
    assert m.locate(40.0, -30.0) is None  # beside the road
    assert m.locate(115.0, -18.25) is None  # beyond its end
    assert m.locate(float("nan"), 0.0) is None
    with pytest.raises(ValueError, match="no road 'x'"):
        m.lane_center("x", -1, 0.0)
    with pytest.raises(ValueError, match="no lane -2"):
        m.lane_center("r", -2, 10.0)
    with pytest.raises(ValueError, match="outside road"):
        m.position_to_world("r", 150.0)


def test_arc_points_lie_on_the_analytic_circle(tmp_path: Path) -> None:
    R, hdg0 = 50.0, 0.3
    m = write_map(tmp_path, road("a", 100, geom(5, -7, hdg0, 100, f'<arc curvature="{1 / R}"/>')))
    centre = np.array([5 - R * math.sin(hdg0), -7 + R * math.cos(hdg0)])
    for s in (0.0, 17.3, 50.0, 99.0):
        x, z, yaw = m.position_to_world("a", s)
        ang = hdg0 + s / R
        expect = centre + R * np.array([math.sin(ang), -math.cos(ang)])
        assert (x, -z) == pytest.approx(tuple(expect), abs=1e-9)
        assert yaw == pytest.approx(ang - math.pi / 2)
        # the right lane is outside the left-turning arc: radius R + 1.75, and locate finds it at s
        lx, lz, _ = m.lane_center("a", -1, s)
        assert math.dist((lx, -lz), centre) == pytest.approx(R + 1.75, abs=1e-6)
        loc = m.locate(lx, lz)
        assert loc is not None and loc[:2] == ("a", -1) and loc[2] == pytest.approx(s, abs=1e-6)


def test_spiral_curvature_grows_linearly(tmp_path: Path) -> None:
    k1, L = 0.05, 100.0
    m = write_map(tmp_path, road("c", L, geom(0, 0, 0.2, L, f'<spiral curvStart="0.0" curvEnd="{k1}"/>')))
    s = np.arange(0.0, L + 1e-9, 0.5)
    kappa = menger_curvature(od_xy(m, "c", s))
    assert kappa == pytest.approx(k1 / L * s[1:-1], abs=2e-5)
    # end heading = hdg + k1 L / 2; end point against an independent fine integration
    assert m.position_to_world("c", L)[2] == pytest.approx(0.2 + k1 * L / 2 - math.pi / 2)
    u = np.linspace(0.0, L, 200_001)
    th = 0.2 + 0.5 * (k1 / L) * u**2
    x_end = np.trapezoid(np.cos(th), u)
    y_end = np.trapezoid(np.sin(th), u)
    assert tuple(od_xy(m, "c", np.array([L]))[0]) == pytest.approx((x_end, y_end), abs=1e-6)


def _arc_length(du, dv, p_end: float) -> float:
    p = np.linspace(0.0, p_end, 400_001)
    return float(np.trapezoid(np.hypot(du(p), dv(p)), p))


@pytest.mark.parametrize("kind", ["paramPoly3-normalized", "paramPoly3-arcLength", "poly3"])
def test_polynomial_geometries_follow_their_curve_by_arc_length(tmp_path: Path, kind: str) -> None:
    x0, y0, hdg0 = 5.0, 5.0, math.pi / 4
    if kind == "paramPoly3-normalized":  # u = 40 p, v = 10 p^2, p in [0, 1]
        length = _arc_length(lambda p: 40 + 0 * p, lambda p: 20 * p, 1.0)
        shape = '<paramPoly3 aU="0" bU="40" cU="0" dU="0" aV="0" bV="0" cV="10" dV="0" pRange="normalized"/>'
        end, on_curve = (40.0, 10.0), lambda u, v: v - u**2 / 160
    elif kind == "paramPoly3-arcLength":  # u = p, v = 0.005 p^2, p in [0, length]
        length = 40.0
        shape = '<paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="0.005" dV="0" pRange="arcLength"/>'
        end, on_curve = (40.0, 8.0), lambda u, v: v - 0.005 * u**2
    else:  # v = 0.01 u^2 up to u = 30
        length = _arc_length(lambda u: 1 + 0 * u, lambda u: 0.02 * u, 30.0)
        shape = '<poly3 a="0" b="0" c="0.01" d="0"/>'
        end, on_curve = (30.0, 9.0), lambda u, v: v - 0.01 * u**2
    m = write_map(tmp_path, road("p", length, geom(x0, y0, hdg0, length, shape)))
    s = np.linspace(0.0, length, 41)
    xy = od_xy(m, "p", s) - (x0, y0)
    c, sn = math.cos(hdg0), math.sin(hdg0)
    u, v = xy[:, 0] * c + xy[:, 1] * sn, -xy[:, 0] * sn + xy[:, 1] * c  # back into the geometry's frame
    assert np.abs(on_curve(u, v)).max() < 1e-6
    assert (u[-1], v[-1]) == pytest.approx(end, abs=1e-6)
    steps = np.hypot(*np.diff(od_xy(m, "p", np.linspace(0.0, length, 201)), axis=0).T)
    if kind != "paramPoly3-arcLength":  # s is true arc length: equal s steps give equal chords
        assert steps == pytest.approx(np.full_like(steps, length / 200), rel=1e-3)


def test_lane_widths_offset_and_sections_decide_the_lane(tmp_path: Path) -> None:
    lanes = """<lanes><laneOffset s="0" a="0.5" b="0" c="0" d="0"/>
      <laneSection s="0">
        <left><lane id="1" type="driving">
          <width sOffset="0" a="3" b="0" c="0" d="0"/><width sOffset="30" a="4" b="0" c="0" d="0"/></lane></left>
        <center><lane id="0" type="none"/></center>
        <right>
          <lane id="-1" type="driving"><width sOffset="0" a="3" b="0.02" c="0" d="0"/></lane>
          <lane id="-2" type="driving"><width sOffset="0" a="2" b="0" c="0.001" d="0"/></lane>
          <lane id="-3" type="border"><width sOffset="0" a="1" b="0" c="0" d="0"/></lane>
        </right>
      </laneSection>
      <laneSection s="60">
        <left><lane id="1" type="driving"><width sOffset="0" a="4" b="0" c="0" d="0"/></lane></left>
        <center><lane id="0" type="none"/></center>
        <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></right>
      </laneSection></lanes>"""
    m = write_map(tmp_path, road("w", 100, geom(0, 0, 0.0, 100, "<line/>"), lanes=lanes))

    def at(s: float, t: float):  # world point of (s, t) on this eastbound road
        return m.locate(s, -t)

    s = 20.0
    w1, w2 = 3 + 0.02 * s, 2 + 0.001 * s * s  # -1 spans t in [0.5 - w1, 0.5], -2 below it
    assert at(s, 0.5 - 0.01) == ("w", -1, pytest.approx(s))
    assert at(s, 0.5 - w1 + 0.01) == ("w", -1, pytest.approx(s))
    assert at(s, 0.5 - w1 - 0.01) == ("w", -2, pytest.approx(s))
    assert at(s, 0.5 - w1 - w2 + 0.01) == ("w", -2, pytest.approx(s))
    assert at(s, 0.5 - w1 - w2 - 0.5)[1] == -3  # the border lane is a lane too ...
    assert m.locate(s, -(0.5 - w1 - w2 - 0.5), lane_types={"driving"}) is None  # ... but not a driving lane
    assert at(s, 0.5 + 2.9) == ("w", 1, pytest.approx(s))
    assert at(s, 0.5 + 3.1) is None
    assert at(40.0, 0.5 + 3.9)[1] == 1  # second width record (sOffset 30): 4 m wide
    assert at(70.0, 0.5 - 3.5 - 1.0) is None  # lane -2 ends with the first section
    x, z, _ = m.lane_center("w", -2, s)
    assert (x, -z) == pytest.approx((s, 0.5 - w1 - w2 / 2))


def test_malformed_xodr_errors_name_file_line_and_element(tmp_path: Path) -> None:
    bad = tmp_path / "broken.xodr"
    bad.write_text('<?xml version="1.0"?>\n<OpenDRIVE>\n  <road id="r" length="10">\n</OpenDRIVE>\n', encoding="utf-8")
    with pytest.raises(OpenDriveError, match=r"broken\.xodr:\d+.*malformed XML"):
        OpenDriveMap.load(bad)
    body = road("r", 10, '<geometry s="0" x="0" y="0" length="10"><line/></geometry>')
    with pytest.raises(OpenDriveError, match=r"map\.xodr:4 <geometry>: attribute 'hdg' is required") as e:
        write_map(tmp_path, body)
    assert e.value.line == 4 and e.value.element == "geometry"
    wrong_side = LANES_2.replace('<left><lane id="1"', '<left><lane id="-5"')
    with pytest.raises(OpenDriveError, match=r"<lane>: lane id -5 does not belong in <left>"):
        write_map(tmp_path, road("r", 10, geom(0, 0, 0, 10, "<line/>"), lanes=wrong_side), name="side.xodr")
    with pytest.raises(OpenDriveError, match="unknown geometry type <clothoid>"):
        write_map(tmp_path, road("r", 10, geom(0, 0, 0, 10, "<clothoid/>")), name="kind.xodr")
    # a dangling link is logged and dropped; the map still loads
    m = write_map(tmp_path, road("r", 10, geom(0, 0, 0, 10, "<line/>"), link='<successor elementType="road" elementId="nope"/>'), "d.xodr")
    assert any("'nope', which does not exist" in w for w in m.warnings)
    assert m.route("r", -1, 0.0).shape == (11, 2)


# ---------------------------------------------------------------------- junctions and routes
def junction_map(tmp_path: Path) -> OpenDriveMap:
    """A (east) -> junction J -> C1 straight to B (east) or C2 left quarter circle (R 20) to D (north)."""
    R = 20.0
    right_only = LANES_2.replace(LEFT_1, "")
    from_a = '<predecessor elementType="road" elementId="A" contactPoint="end"/>'

    body = "\n".join(
        [
            road("A", 100, geom(0, 0, 0, 100, "<line/>"), link='<successor elementType="junction" elementId="J"/>'),
            road(
                "C1",
                20,
                geom(100, 0, 0, 20, "<line/>"),
                right_only,
                from_a + '<successor elementType="road" elementId="B" contactPoint="start"/>',
                "J",
            ),
            road(
                "C2",
                math.pi * R / 2,
                geom(100, 0, 0, math.pi * R / 2, f'<arc curvature="{1 / R}"/>'),
                right_only,
                from_a + '<successor elementType="road" elementId="D" contactPoint="start"/>',
                "J",
            ),
            road("B", 100, geom(120, 0, 0, 100, "<line/>"), link='<predecessor elementType="junction" elementId="J"/>'),
            road("D", 100, geom(120, 20, math.pi / 2, 100, "<line/>"), link='<predecessor elementType="junction" elementId="J"/>'),
            '<junction id="J" name="J">'
            '<connection id="0" incomingRoad="A" connectingRoad="C1" contactPoint="start"><laneLink from="-1" to="-1"/></connection>'
            '<connection id="1" incomingRoad="A" connectingRoad="C2" contactPoint="start"><laneLink from="-1" to="-1"/></connection>'
            "</junction>",
        ]
    )
    return write_map(tmp_path, body)


def test_route_follows_junction_connections(tmp_path: Path) -> None:
    m = junction_map(tmp_path)
    straight = m.route("A", -1, 10.0)  # first valid connection: C1, then B to its end
    assert straight[0] == pytest.approx((10.0, 1.75)) and straight[-1] == pytest.approx((220.0, 1.75))
    steps = np.hypot(*np.diff(straight, axis=0).T)
    assert steps.max() <= 1.0 + 1e-9 and steps.min() > 0.0
    assert len(straight) == pytest.approx(211, abs=2)
    left = m.route("A", -1, 10.0, preferred_connections=[ODConnection(junction_id="J", connection_id="1")])
    assert left[-1] == pytest.approx((121.75, -120.0))  # D's right lane, heading north (world -Z)
    on_arc = left[(left[:, 0] > 105.0) & (left[:, 0] < 118.0)]
    mid = on_arc[len(on_arc) // 2]
    assert math.dist(mid, (100.0, -20.0)) == pytest.approx(21.75)  # C2's right lane, radius R + 1.75
    found = m.locate(*mid)
    assert found is not None and found[:2] == ("C2", -1)  # inside the junction the turning lane is found
    # with a target, the connection that reaches it is taken; the route stops at its s
    to_d = m.route("A", -1, 10.0, target_road_id="D", target_s=50.0)
    assert to_d[-1] == pytest.approx((121.75, -70.0))
    assert m.route("A", -1, 10.0, target_road_id="A", target_s=60.0)[-1] == pytest.approx((60.0, 1.75))
    # a left lane drives towards decreasing s and ends where no connection leaves B's start
    back = m.route("B", 1, 50.0)
    assert back[0] == pytest.approx((170.0, -1.75)) and back[-1] == pytest.approx((120.0, -1.75))
    with pytest.raises(ValueError, match="no lane 2"):
        m.route("A", 2, 0.0)


# ---------------------------------------------------------------------- the corpus task
def test_init_drive_map_loads() -> None:
    m = OpenDriveMap.load(CORPUS / INIT_DRIVE / "road.xodr")
    assert sorted(m.roads) == ["s000", "s001"] and m.roads["s000"].length == 2500.0
    # the file declares the s000 -> s001 contact at s001's end; geometry says start
    assert any("using 'start'" in w for w in m.warnings)
    r = m.route("s000", -2, 2450.0)
    assert r[-1] == pytest.approx((-3200.0, 100 - 2.6 * 1.5), abs=0.05)  # continued onto s001


def test_driver_starts_on_its_opendrive_position() -> None:
    w = World(load_task(CORPUS / INIT_DRIVE), WorldConfig(traffic=False))
    st = w.ego.state
    assert w.road.opendrive is not None and w.road.road_position is not None
    x, z, _ = w.road.opendrive.lane_center("s000", -1, 50.0)
    assert (st.x, st.z) == pytest.approx((x, z)) and (x, z) == pytest.approx((-650.0, 98.7), abs=1e-3)
    assert st.yaw == pytest.approx(math.pi / 2, abs=1e-5)  # s000 runs west (hdg 3.14159): world -X
    assert w.road.road_position(st.x, st.z) == ("s000", -1, pytest.approx(50.0, abs=1e-6))


def _drive_until_trigger(w: World, t_max_s: float) -> tuple[str, int, float] | None:
    """Full throttle straight ahead until a trigger fires; the car's road position then."""
    c = DriverControls(accelerator=1.0)
    locate = w.road.road_position
    assert locate is not None
    while w.t_s < t_max_s:
        w.step(c)
        if w.events.of_kind("trigger"):
            return locate(w.ego.state.x, w.ego.state.z)
    return None


def test_open_drive_pos_trigger_fires_when_the_car_passes(tmp_path: Path) -> None:
    w = World(load_task(CORPUS / INIT_DRIVE), WorldConfig(traffic=False))
    pos = _drive_until_trigger(w, 120.0)
    assert pos is not None and pos[:2] == ("s000", -1) and abs(pos[2] - 1422.0) < 0.5
    fired = w.events.of_kind("trigger")
    assert [(e.source, e.params["cause"]) for e in fired] == [("end_simulation", "condition")]
    assert w.events.of_kind("shutdown")
    assert not any(e.source == "openDrivePos" for e in w.events.of_kind("warning"))


TRIGGERS = """<?xml version="1.0"?>
<interaction xmlns="http://opends.eu/drivingtask/interaction"><activities>
<activity id="a"><action id="reportText" delay="0" repeat="0"><parameter name="text" value="x"/></action></activity></activities>
<triggers>{}</triggers></interaction>"""


def _od_trigger(tid: str, lane: int, s: float, road_id: str = "s000") -> str:
    return (
        f'<trigger id="{tid}" priority="1"><activities><activity ref="a"/></activities>'
        f"<condition><openDrivePos><roadID>{road_id}</roadID><lane>{lane}</lane><s>{s}</s></openDrivePos></condition></trigger>"
    )


@pytest.mark.parametrize(("lane", "start_s", "expected"), [(-2, 1400.0, ["any", "lane-2"]), (1, 1445.0, ["lane1", "any"])])
def test_open_drive_pos_checks_road_lane_and_s(task_copy, lane: int, start_s: float, expected: list[str]) -> None:
    folder = task_copy(INIT_DRIVE, "scenario.xml", "<startLane>-1</startLane>", f"<startLane>{lane}</startLane>")
    text = (folder / "scenario.xml").read_text(encoding="utf-8").replace("<startS>50.0</startS>", f"<startS>{start_s}</startS>")
    (folder / "scenario.xml").write_text(text, encoding="utf-8")
    triggers = [_od_trigger(f"lane{k}", k, 1422.0) for k in (1, -1, -2)] + [
        _od_trigger("any", 0, 1410.0),
        _od_trigger("other", 0, 1422.0, "s001"),
    ]
    (folder / "interaction.xml").write_text(TRIGGERS.format("".join(triggers)), encoding="utf-8")
    w = World(load_task(folder), WorldConfig(traffic=False))
    c = DriverControls(accelerator=1.0)
    while w.t_s < 10.0:
        w.step(c)
    # in the order the car passes them; lane 1 drives towards decreasing s (1422 before 1410)
    assert [e.source for e in w.events.of_kind("trigger")] == expected


def test_without_opendrive_file_open_drive_pos_triggers_warn(task_copy) -> None:
    folder = task_copy(INIT_DRIVE, "init_drive.xml", '<entry key="openDrive">road.xodr</entry>', "")
    w = World(load_task(folder), WorldConfig(traffic=False))
    assert w.road.opendrive is None and w.road.road_position is None
    assert w.start_pose == w.task.start_pose  # the scene pose of the car model
    w.step()
    assert [e.source for e in w.events.of_kind("warning")] == ["openDrivePos"]


def test_scene_models_placed_by_opendrive_position(task_copy) -> None:
    box = (
        '<model id="roadBlock" ref="blockBox"><mass>0</mass><visible>true</visible><collisionShape>boxShape</collisionShape>'
        '<rotation quaternion="false"><vector jtype="java_lang_Float" size="3"><entry>0</entry><entry>0</entry><entry>0</entry>'
        '</vector></rotation><openDrivePosition roadID="s001" s="50" lateralOffset="2.5" verticalOffset="0.3"/></model>\n'
        '\t\t<model id="grassPlane"'
    )
    folder = task_copy("opends2023-annegretj/init_drive", "scene.xml", '<model id="grassPlane"', box)
    scene = folder / "scene.xml"
    text = scene.read_text(encoding="utf-8")
    geometry = '<geometries><box id="blockBox"><width>1</width><depth>1</depth><height>1</height></box>'
    if "<geometries>" in text:
        text = text.replace("<geometries>", geometry, 1)
    else:
        text = text.replace("</models>", "</models>\n" + geometry + "</geometries>", 1)
    scene.write_text(text, encoding="utf-8")
    w = World(load_task(folder))
    od = w.road.opendrive
    assert od is not None
    (obj,) = w.objects.by_id["roadBlock"]
    x, z, yaw = od.position_to_world("s001", 50.0, 2.5)
    assert obj.position == pytest.approx((x, od.elevation_m("s001", 50.0) + 0.3, z))
    assert obj.yaw == pytest.approx(yaw)
