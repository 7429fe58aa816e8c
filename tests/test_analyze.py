"""The Drive Analyzer's figures against values computed by hand on synthetic drives.

Mean deviation (OpenDS algorithm) on a drifting straight drive and around a corner, its
completeness status, SDLP of a known sine, steering reversals of a known sine, headway/TTC
and reaction results by group -- all through `analyze()` on a `Drive`, as for a recording.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from opends_gym.record.analyze import analyze
from opends_gym.record.drive import COLUMNS, Drive
from opends_gym.record.report import GROUP_COLOURS, group_colours


def synthetic(x: np.ndarray, z: np.ndarray, rate_hz: float = 60.0, **cols: Any) -> Drive:
    """A Drive from positions (and any other columns); unspecified columns are neutral."""
    n = len(x)
    base = {name: np.zeros(n) for name in COLUMNS}
    base.update({"t_s": np.arange(n) / rate_hz, "x_m": np.asarray(x, float), "z_m": np.asarray(z, float), "qw": np.ones(n)})
    base.update(
        {"lane_index": np.ones(n), "headway_s": np.full(n, math.inf), "ttc_s": np.full(n, math.inf), "lead_gap_m": np.full(n, math.inf)}
    )
    for k, v in cols.items():
        base[k] = np.asarray(v, dtype=float)
    analysis = {"guide": {"kind": "start_line", "start_xz": [0.0, 0.0], "start_yaw": 0.0, "lane_laterals_m": [0.0], "lane_width_m": 3.5}}
    return Drive("synthetic", Path("synthetic.mcap"), base, analysis=analysis)


def with_track(d: Drive, points: list[tuple[float, float]], width: float = 15.0) -> Drive:
    d.analysis["ideal_tracks"] = {"T1": {"points": [list(p) for p in points], "road_width_m": width}}
    return d


def test_mean_deviation_of_a_drifting_straight_drive() -> None:
    # ideal: 100 m straight along -Z, a point every 10 m; driven: drifting 0.05 m per metre.
    # OpenDS's IdealLine (constructor) sums the quadrangles of the inner points IP1..IP9: the
    # triangle up to IP1 (0.5 * 10 * 0.5 = 2.5) and the trapezoids up to IP9 (2.5 * (2k - 1),
    # k = 2..9: 200); the last 10 m (47.5 m^2) has length but no area. Length: all 100 m.
    dist = np.arange(-5.0, 105.0 + 1e-9, 0.5)
    drive = with_track(synthetic(0.05 * dist, -dist), [(0.0, -10.0 * k) for k in range(11)])
    (dev,) = analyze(drive).deviations
    assert dev.result.area_m2 == pytest.approx(202.5, abs=1e-4)
    assert dev.result.length_m == pytest.approx(100.0)
    assert dev.result.mean_deviation_m == pytest.approx(2.025, abs=1e-6)
    assert str(dev.result.status) == "Complete"


def test_mean_deviation_around_a_corner_uses_the_bisector() -> None:
    # ideal: 50 m along -Z to (0, -50), then a right turn and 50 m along +X (points every
    # 10 m); driven: the outer parallel path h = 2 m away, its corner on the 45-degree
    # bisector (IdealLine.getHalfwayVector). Area (IdealLine constructor): the triangle up to
    # IP1 (10), 6 rectangles 10 m x h, the 2 quads at the corner (10 + 10 + h) / 2 * h each.
    h = 2.0
    ideal = [(0.0, -10.0 * k) for k in range(6)] + [(10.0 * k, -50.0) for k in range(1, 6)]
    leg1 = [(-h, z) for z in np.arange(5.0, -50.0 - h, -0.25)]
    leg2 = [(x, -50.0 - h) for x in np.arange(-h, 55.0 + 1e-9, 0.25)]
    path = np.asarray(leg1 + leg2)
    (dev,) = analyze(with_track(synthetic(path[:, 0], path[:, 1]), ideal)).deviations
    area = 0.5 * 10.0 * h + 6 * 10.0 * h + 2 * (10.0 + 10.0 + h) / 2 * h
    assert dev.result.area_m2 == pytest.approx(area, abs=1e-3)
    assert dev.result.mean_deviation_m == pytest.approx(area / 100.0, abs=1e-5)  # = 0.85 h + h^2 / 100 = 1.74
    assert dev.result.driven_points[5] == pytest.approx((-h, -50.0 - h))
    assert str(dev.result.status) == "Complete"


def test_mean_deviation_status_of_a_drive_that_stops_half_way() -> None:
    dist = np.arange(-5.0, 55.0, 0.5)
    drive = with_track(synthetic(np.full(len(dist), 1.5), -dist), [(0.0, -10.0 * k) for k in range(11)])
    # driven points found at IP1..IP5 only (IdealLine.getPointOnLine): the area is the triangle
    # 0.5 * 10 * 1.5 and 4 rectangles 10 x 1.5; IncompleteEnd counts the segments after
    # IP1..IP5 and the first one: 60 m
    (dev,) = analyze(drive).deviations
    assert str(dev.result.status) == "IncompleteEnd"
    assert dev.result.area_m2 == pytest.approx(67.5) and dev.result.length_m == pytest.approx(60.0)
    assert dev.result.mean_deviation_m == pytest.approx(1.125, abs=1e-6)


def test_unknown_ideal_track_is_a_clear_error() -> None:
    drive = with_track(synthetic(np.zeros(10), -np.arange(10.0)), [(0.0, 0.0), (0.0, -10.0)])
    with pytest.raises(ValueError, match=r"no ideal track 'nope'.*known: T1"):
        analyze(drive, ideal_track="nope")


def test_sdlp_of_a_known_sine_and_lane_change_exclusion() -> None:
    amp, f, fs = 0.3, 0.2, 60.0
    t = np.arange(int(20.0 * fs)) / fs  # four whole periods
    offset = amp * np.sin(2 * math.pi * f * t)
    drive = synthetic(np.zeros(len(t)), -16.0 * t, lane_offset_m=offset)
    a = analyze(drive)
    assert a.lateral["sdlp_m"] == pytest.approx(amp / math.sqrt(2.0), abs=1e-12)
    assert a.lateral["lane_keeping_fraction"] == 1.0
    # a lane change at t = 10 s: samples within 2.5 s of it are not lane keeping
    lane = np.where(t < 10.0, 1.0, 2.0)
    b = analyze(synthetic(np.zeros(len(t)), -16.0 * t, lane_offset_m=offset, lane_index=lane))
    assert b.lateral["lane_keeping_fraction"] == pytest.approx(np.mean(np.abs(t - 10.0) > 2.5))


def test_steering_reversal_rate_of_a_known_sine() -> None:
    fs, f = 60.0, 0.1
    t = np.arange(int(60.0 * fs)) / fs
    wheel_deg = 10.0 * np.sin(2 * math.pi * f * t)  # 10 degrees of steering wheel, 6 periods
    a = analyze(synthetic(np.zeros(len(t)), -16.0 * t, steering=wheel_deg / 450.0))
    # turning points: the start (0 deg), 12 extrema (+-10 deg at 2.5, 7.5, ..., 57.5 s) and the end
    # (~0 deg); all 13 movements between them exceed the 2-degree gap, over t[-1] = 59.98 s
    assert a.steering["reversal_rate_per_min"] == pytest.approx(13.0 / (t[-1] / 60.0))
    quiet = analyze(synthetic(np.zeros(len(t)), -16.0 * t, steering=0.5 * np.sin(2 * math.pi * f * t) / 450.0))
    assert quiet.steering["reversal_rate_per_min"] == 0.0  # 1-degree swings stay under the 2-degree gap


def test_headway_and_ttc_summaries() -> None:
    n, fs = 100, 10.0
    headway = np.where(np.arange(n) < 50, 1.5, math.inf)
    headway[10:20] = 0.8
    ttc = np.full(n, math.inf)
    ttc[20:50] = 2.0
    a = analyze(synthetic(np.zeros(n), -np.arange(n, dtype=float), rate_hz=fs, headway_s=headway, ttc_s=ttc))
    assert a.headway["mean_s"] == pytest.approx((40 * 1.5 + 10 * 0.8) / 50)
    assert a.headway["min_s"] == 0.8 and a.headway["fraction_below_threshold"] == pytest.approx(10 / 50)
    assert a.ttc["min_s"] == 2.0
    assert a.ttc["time_exposed_s"] == pytest.approx(30 / fs)
    assert a.ttc["time_integrated_s2"] == pytest.approx(30 * (3.0 - 2.0) / fs)


def test_reaction_results_by_group_and_their_colours() -> None:
    d = synthetic(np.zeros(50), -np.arange(50.0))
    d.reactions = [
        {"timer_id": "b1", "group": "Brake", "result": 1, "reaction_time_s": 0.8, "t_s": 1.0},
        {"timer_id": "l1", "group": "LaneChange", "result": 1, "reaction_time_s": 1.5, "t_s": 2.0},
        {"timer_id": "b2", "group": "Brake", "result": 1, "reaction_time_s": 1.0, "t_s": 3.0},
        {"timer_id": "l2", "group": "LaneChange", "result": -1, "reaction_time_s": 0.9, "t_s": 4.0},
        {"timer_id": "b3", "group": "Brake", "result": -2, "reaction_time_s": 10.0, "t_s": 5.0},
        {"timer_id": "x1", "group": "Other", "result": 1, "reaction_time_s": 0.5, "t_s": 6.0},
    ]
    d.analysis["reaction_groups"] = {"Brake": "red", "LaneChange": "magenta"}
    a = analyze(d)
    brake, lane = a.groups["Brake"], a.groups["LaneChange"]
    assert (brake["trials"], brake["correct"], brake["misses"], brake["failures"]) == (3, 2, 1, 0)
    assert brake["hit_rate"] == pytest.approx(2 / 3) and brake["mean_rt_s"] == pytest.approx(0.9)
    assert brake["sd_rt_s"] == pytest.approx(math.sqrt(((0.8 - 0.9) ** 2 + (1.0 - 0.9) ** 2) / 1))
    assert (lane["correct"], lane["failures"], lane["mean_rt_s"]) == (1, 1, 1.5)
    assert a.groups["all"]["trials"] == 6 and a.groups["all"]["mean_rt_s"] == pytest.approx((0.8 + 1.5 + 1.0 + 0.5) / 4)
    colours = group_colours(a)
    assert colours["Brake"] == GROUP_COLOURS["red"] and colours["LaneChange"] == GROUP_COLOURS["magenta"]
    assert colours["Other"] not in GROUP_COLOURS.values()
