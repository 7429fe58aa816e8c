"""The road guide: where a point lies along the task's reference line."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from opends_gym.sim.guide import RoadGuide
from opends_gym.task.model_task import Pose
from opends_gym.task.values import Rotation


def _start_line_guide(x: float, z: float, yaw_deg: float) -> RoadGuide:
    """The guide of a task with neither lanes nor an ideal track: the start heading's line."""
    start = Pose((x, 0.0, z), Rotation.from_euler_deg(0.0, yaw_deg, 0.0))
    world = SimpleNamespace(task=SimpleNamespace(start_pose=start), road=SimpleNamespace(lanes=(), ideal_tracks={}))
    guide = RoadGuide(world)  # type: ignore[arg-type]
    assert guide.kind == "start_line"
    return guide


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, -135.0])
def test_start_line_lane_position_measures_along_and_across_the_start_heading(yaw_deg: float) -> None:
    g = _start_line_guide(10.0, -20.0, yaw_deg)
    yaw = math.radians(yaw_deg)
    forward, left = (-math.sin(yaw), -math.cos(yaw)), (-math.cos(yaw), math.sin(yaw))
    for along, across in ((0.0, 0.0), (30.0, 1.0), (-5.0, -1.74), (12.0, 1.76), (50.0, -8.0)):
        x = 10.0 + along * forward[0] + across * left[0]
        z = -20.0 + along * forward[1] + across * left[1]
        s, lat, lane, offset = g.lane_position(x, z)
        assert s == pytest.approx(along, abs=1e-9) and lat == pytest.approx(across, abs=1e-9)
        assert lane == (0 if abs(across) < 1.75 else -1)  # one lane, 3.5 m wide, on the line
        assert offset == lat  # measured from that lane's centre, on or off it
        p = g.locate(x, z)  # the same floats as the full answer
        assert (p.s_m, p.lateral_m, p.lane_index) == (s, lat, lane)


def test_locate_answers_each_new_position_after_repeated_questions() -> None:
    """The guide keeps its last answer for the same position; a moved car gets a new one."""
    g = _start_line_guide(0.0, 0.0, 0.0)
    first = g.locate(0.5, -10.0)
    assert g.locate(0.5, -10.0) == first
    moved = g.locate(-1.0, -12.5)
    assert (moved.s_m, moved.lateral_m) == (12.5, 1.0)
    assert g.locate(0.5, -10.0) == first


def test_pedal_controls_equal_the_full_constructor() -> None:
    from opends_gym.sim.controls import DriverControls

    fast = DriverControls.pedals(-0.25, 0.5, 0.0)
    assert fast == DriverControls(steering=-0.25, accelerator=0.5, brake=0.0)
    fast.keys = ("KEY_A",)  # its own record: changing it leaves the defaults alone
    assert DriverControls.pedals(0.0, 0.0, 0.0).keys == () and DriverControls().keys == ()


def test_nearest_lane_is_the_closest_centre_and_the_first_of_equals() -> None:
    g = _start_line_guide(0.0, 0.0, 0.0)
    g.lane_laterals_m = (-3.5, 0.0, 3.5)
    assert [g.nearest_lane(v) for v in (-9.0, -1.0, 1.0, 1.75, 2.0, 40.0)] == [0, 1, 1, 1, 2, 2]
