"""The Drive Analyzer's mean deviation against OpenDS's own algorithm, on cases worked by hand.

Each test names the OpenDS method whose behaviour it pins (`eu.opends.analyzer.IdealLine`,
`DeviationQuadrangle`, `DeviationComputer`). Ideal points every 10 m along +X on z = 0
unless a test says otherwise; the driven path is sampled every 0.5 m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from opends_gym.metrics import Completeness, mean_deviation
from opends_gym.metrics.deviation import quad_area

IDEAL_11 = [(10.0 * k, 0.0) for k in range(11)]  # 0 .. 100 m


def along_x(x0: float, x1: float, z: float, step: float = 0.5) -> np.ndarray:
    x = np.arange(x0, x1 + 1e-9, step)
    return np.column_stack([x, np.full_like(x, z)])


@pytest.mark.parametrize(("n", "expected"), [(3, 0.25), (5, 0.625), (11, 0.85)])
def test_idealline_constant_one_metre_offset(n: int, expected: float) -> None:
    # IdealLine(...) constructor: only IP(1)..IP(n-2) are processed; the first quadrangle
    # starts at IP(0) itself (prevWP = idealPoints.get(0)), so it is the triangle
    # IP0-WP1-IP1 (area 5 = 0.5 * 10 m * 1 m); each further one is 10 m x 1 m; the last
    # segment gets length but no area. Area 5 + 10 (n - 3), length 10 (n - 1):
    # (n - 2.5) / (n - 1) = 0.85 for 11 points, where the offset is 1 m.
    ideal = [(10.0 * k, 0.0) for k in range(n)]
    res = mean_deviation(along_x(-5.0, 10.0 * n, 1.0), ideal)
    assert res.status is Completeness.COMPLETE
    assert res.area_m2 == pytest.approx(5.0 + 10.0 * (n - 3))
    assert res.length_m == pytest.approx(10.0 * (n - 1))
    assert res.mean_deviation_m == pytest.approx(expected, abs=1e-6)


def test_idealline_first_and_last_ideal_points_are_never_processed() -> None:
    # IdealLine(...) loops i = 1 .. n-2: no driven point is searched at IP(0) or IP(n-1).
    # Swerving 5 m off before IP(1) or after IP(9) changes nothing: the swerves are not
    # between two processed points, and WP(1) = (10, 0) lies on the ideal line.
    x = np.arange(-5.0, 105.0 + 1e-9, 0.5)
    z = np.where((x > 1.0) & (x < 9.0), 5.0, 0.0) + np.where(x > 91.0, 5.0, 0.0)
    res = mean_deviation(np.column_stack([x, z]), IDEAL_11)
    assert res.driven_points[0] is None and res.driven_points[-1] is None
    assert res.driven_points[1] == pytest.approx((10.0, 0.0))
    assert res.area_m2 == 0.0 and res.length_m == pytest.approx(100.0)
    assert res.mean_deviation_m == 0.0


def test_idealline_bridges_a_gap_from_the_last_found_point() -> None:
    # IdealLine(...): a missing point (getPointOnLine throws NotFinishedException) adds
    # neither area nor length and keeps prevWP; the next quadrangle spans the gap:
    # (WP3, WP7, IP7, IP6) = (30,1), (70,1), (70,0), (60,0), a trapezoid of area 25.
    # No recording between x = 35 and 65: IP4..IP6 see positions on one side only.
    path = np.concatenate([along_x(-5.0, 35.0, 1.0), along_x(65.0, 105.0, 1.0)])
    res = mean_deviation(path, IDEAL_11)
    assert [p is None for p in res.driven_points] == [True, False, False, False, True, True, True, False, False, False, True]
    assert res.status is Completeness.INCOMPLETE  # found, missing, found again
    assert res.area_m2 == pytest.approx(5.0 + 10.0 + 10.0 + 25.0 + 10.0 + 10.0)
    # length per processed point: segments after IP1, IP2, IP3, IP7, IP8, IP9; not |IP0 IP1| (Incomplete)
    assert res.length_m == pytest.approx(60.0)
    assert res.mean_deviation_m == pytest.approx(70.0 / 60.0, abs=1e-6)


def test_idealline_missing_beginning_bridges_from_ideal_point_zero() -> None:
    # IdealLine(...): with IP1..IP3 missing, prevWP is still IP(0), so the first quadrangle
    # is (IP0, WP4, IP4, IP3) = (0,0), (40,1), (40,0), (30,0): area 0.5 * 40 * 1 = 20.
    # IncompleteBeginning: |IP0 IP1| is not added to the length.
    res = mean_deviation(along_x(35.0, 105.0, 1.0), IDEAL_11)
    assert res.status is Completeness.INCOMPLETE_BEGINNING
    assert res.area_m2 == pytest.approx(20.0 + 5 * 10.0)
    assert res.length_m == pytest.approx(60.0)
    assert res.mean_deviation_m == pytest.approx(70.0 / 60.0, abs=1e-6)


def test_idealline_missing_end_still_counts_the_first_segment() -> None:
    # IdealLine(...): IncompleteEnd (and Complete) add |IP0 IP1| = 10 m to the length.
    # Found IP1..IP6 (positions up to x = 65 on both sides of IP6's line), missing IP7..IP9.
    res = mean_deviation(along_x(-5.0, 65.0, 1.0), IDEAL_11)
    assert res.status is Completeness.INCOMPLETE_END
    assert res.area_m2 == pytest.approx(5.0 + 5 * 10.0)
    assert res.length_m == pytest.approx(60.0 + 10.0)
    assert res.mean_deviation_m == pytest.approx(55.0 / 70.0, abs=1e-6)


def test_idealline_status_sequence() -> None:
    # IdealLine(...) status updates: missing at both ends; everything missing is Unavailable
    # (DriveAnalyzer then prints nothing; we give NaN).
    both = mean_deviation(along_x(35.0, 65.0, 1.0), IDEAL_11)
    assert both.status is Completeness.INCOMPLETE_BEGINNING_AND_END
    assert both.length_m == pytest.approx(30.0)  # segments after IP4, IP5, IP6 only
    none = mean_deviation(along_x(-5.0, 105.0, 30.0), IDEAL_11)
    assert none.status is Completeness.UNAVAILABLE and math.isnan(none.mean_deviation_m)


@pytest.mark.parametrize(("offset", "found"), [(9.0, True), (17.0, True), (18.0, False)])
def test_getpointonline_filters_at_ten_metres_from_the_cross_segment(offset: float, found: bool) -> None:
    # IdealLine.getPointOnLine: a position is ignored when line.ptSegDist > MAX_DISTANCE (10 m),
    # the distance to the cross *segment* (half-length roadWidth / 2 = 7.5 m), not to the
    # infinite line. At 9 m and 17 m off (9.5 m from the segment's end) the positions count,
    # and the driven point is where they cross the infinite line, beyond the segment (a
    # position there is "left" of it for relativeCCW, at distance 0 from the line);
    # at 18 m (10.5 m from the end) every point is missing.
    res = mean_deviation(along_x(-5.0, 105.0, offset), IDEAL_11)
    if found:
        assert res.status is Completeness.COMPLETE
        assert res.driven_points[5] == pytest.approx((50.0, offset))
        assert res.mean_deviation_m == pytest.approx(0.85 * offset, rel=1e-6)
    else:
        assert res.status is Completeness.UNAVAILABLE


def test_getpointonline_ignores_positions_far_along_the_track() -> None:
    # IdealLine.getPointOnLine: with positions every 25 m, IP(i)'s line often has recorded
    # positions within 10 m on one side only; the straight line between two recordings
    # crossing it does not count. Positions at x = -5, 20, 45, 70, 95 (z = 1):
    # IP2 (20) and IP7 (70) are hit exactly (relativeCCW == 0 returns that position); IP1
    # sees only 20 (-5 is 15 m away), IP3 only 20, IP4 and IP5 only 45, IP6 and IP8 only 70,
    # IP9 only 95: one side each, so they are missing.
    path = np.array([(-5.0, 1.0), (20.0, 1.0), (45.0, 1.0), (70.0, 1.0), (95.0, 1.0)])
    res = mean_deviation(path, IDEAL_11)
    found = [i for i, p in enumerate(res.driven_points) if p is not None]
    assert found == [2, 7]
    assert res.status is Completeness.INCOMPLETE
    # (IP0, WP2, IP2, IP1) = triangle 0.5 * 20 * 1; (WP2, WP7, IP7, IP6) = trapezoid (50 + 10) / 2
    assert res.area_m2 == pytest.approx(10.0 + 30.0)
    assert res.length_m == pytest.approx(20.0)


def test_getpointonline_takes_the_first_crossing_of_the_whole_drive() -> None:
    # IdealLine.getPointOnLine scans the recording from its first position for every ideal
    # point: a drive that goes out 1 m left and comes back 3 m right is measured on the way out.
    path = np.concatenate([along_x(-5.0, 45.0, 1.0), along_x(45.0, -5.0, -3.0, step=-0.5)])
    res = mean_deviation(path, [(10.0 * k, 0.0) for k in range(5)])
    assert [p for p in res.driven_points[1:4]] == [pytest.approx((10.0 * k, 1.0)) for k in (1, 2, 3)]
    assert res.mean_deviation_m == pytest.approx(0.625, abs=1e-6)


def test_getpointonline_interpolates_the_last_positions_either_side() -> None:
    # IdealLine.getPointOnLine: the last position left of the line and the first right of it,
    # weighted by their distances from the line: (8, 0) and (14, 3) cross x = 10 at
    # (8, 0) * 4/6 + (14, 3) * 2/6 = (10, 1).
    path = np.array([(-5.0, 0.0), (8.0, 0.0), (14.0, 3.0), (16.0, 3.0), (24.0, 3.0)])
    res = mean_deviation(path, [(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)])
    assert res.driven_points[1] == pytest.approx((10.0, 1.0))
    assert res.area_m2 == pytest.approx(5.0)  # triangle IP0, (10, 1), IP1


def test_gethalfwayvector_bisects_the_corner() -> None:
    # IdealLine.getHalfwayVector: at a 90-degree corner the cross line is the 45-degree
    # bisector. Ideal: (0, 50) .. (0, 0) along -Z, then (10, 0) .. (50, 0); driven: the outer
    # parallel path h = 2 m away, its corner (-2, -2) on the bisector. Areas: triangle 10,
    # six rectangles 20, the two corner quadrangles (10 + 12) / 2 * 2 = 22 each.
    h = 2.0
    ideal = [(0.0, 50.0 - 10.0 * k) for k in range(6)] + [(10.0 * k, 0.0) for k in range(1, 6)]
    leg1 = np.column_stack([np.full(229, -h), np.arange(55.0, -h - 1e-9, -0.25)[:229]])
    leg2 = np.column_stack([np.arange(-h, 55.0 + 1e-9, 0.25), np.full(229, -h)])
    res = mean_deviation(np.concatenate([leg1, leg2]), ideal)
    assert res.driven_points[5] == pytest.approx((-h, -h))
    assert res.area_m2 == pytest.approx(10.0 + 6 * 20.0 + 2 * 22.0)
    assert res.mean_deviation_m == pytest.approx(1.74, abs=1e-6)


def test_deviationquadrangle_area_by_hand() -> None:
    # DeviationQuadrangle.getArea: a simple quadrangle by its diagonals (trapezoid 1 m and 3 m
    # over 10 m = 20); a crossing one as two triangles meeting at the crossing (+2 to -2 over
    # 10 m: 5 + 5), never as a signed area that would cancel.
    assert quad_area(np.array([0.0, 1.0]), np.array([10.0, 3.0]), np.array([10.0, 0.0]), np.array([0.0, 0.0])) == pytest.approx(20.0)
    assert quad_area(np.array([0.0, 2.0]), np.array([10.0, -2.0]), np.array([10.0, 0.0]), np.array([0.0, 0.0])) == pytest.approx(10.0)


def test_deviationcomputer_drops_lines_openDS_refuses() -> None:
    # IdealLine(...) throws for fewer than 3 ideal points, getHalfwayVector for three
    # identical ones; DeviationComputer.getIdealLines prints the reason and skips the line.
    short = mean_deviation(along_x(-5.0, 25.0, 1.0), [(0.0, 0.0), (20.0, 0.0)])
    assert short.status is Completeness.UNAVAILABLE and "3" in short.problem
    same = mean_deviation(along_x(-5.0, 25.0, 1.0), [(0.0, 0.0), (0.0, 0.0), (0.0, 0.0)])
    assert same.status is Completeness.UNAVAILABLE and "identical" in same.problem


def test_bucketing_positions_does_not_change_the_answer(monkeypatch: pytest.MonkeyPatch) -> None:
    # the cells that speed up getPointOnLine's scan must give what scanning every position gives:
    # a wandering drive that loops back over its own track, against a curved ideal track
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 4.0 * np.pi, 3000)
    path = np.column_stack([60.0 * np.cos(t) + np.cumsum(rng.normal(0, 0.05, len(t))), 40.0 * np.sin(t)])
    ideal = np.column_stack([60.0 * np.cos(t[::40]), 40.0 * np.sin(t[::40])])[:40]
    fast = mean_deviation(path, ideal)
    monkeypatch.setattr("opends_gym.metrics.deviation.CELL_M", 1e9)  # one cell: every position scanned
    slow = mean_deviation(path, ideal)
    assert fast == slow and fast.status is Completeness.COMPLETE
