"""The analyzer on real OpenDS drive logs: lateral position measured from where the log starts.

The real Countryside logs (tests/data/opends-drives) start where `startRecording` fired,
up to 340 m from the task's start pose; the task has no lanes and no ideal track. Their
lateral offset must be measured from a reference anchored at the log's own first position.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from opends_gym.record.analyze import analyze
from opends_gym.record.cardata import write_cardata
from opends_gym.record.drive import load_drive
from opends_gym.record.reference import route_polylines
from opends_gym.task import load_task

from .conftest import DRIVES

TASK = DRIVES / "Countryside"
LOGS = sorted((DRIVES / "drives").glob("*/carData*.txt"))


def write_log(path: Path, xz: np.ndarray) -> Path:
    """A classic carData.txt driving through the (x, z) points at 20 Hz, heading along them."""
    d = np.diff(xz, axis=0)
    d = np.vstack([d, d[-1:]])
    yaw = np.arctan2(-d[:, 0], -d[:, 1])  # jME: yaw 0 heads -Z
    n = len(xz)
    q = np.column_stack([np.zeros(n), np.sin(yaw / 2), np.zeros(n), np.cos(yaw / 2)])
    zeros = np.zeros(n)
    return write_cardata(
        path, np.arange(n) / 20.0, xz[:, 0], np.full(n, 20.0), xz[:, 1], q, np.full(n, 50.0), zeros, zeros, zeros, np.ones(n)
    )


def test_the_real_logs_are_there() -> None:
    assert len(LOGS) == 6


@pytest.mark.parametrize("log", LOGS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_real_countryside_drive_has_a_plausible_lane_offset(log: Path) -> None:
    d = load_drive(log, task=TASK)
    guide = d.analysis["guide"]
    assert guide["start_xz"] == [d.col("x_m")[0], d.col("z_m")[0]]
    # measured: 0.75 .. 1.18 m (a keyboard driver keeping to the right of the traffic route);
    # from the task's start pose it was up to 340 m
    a = analyze(d)
    assert a.lateral["mean_abs_lane_offset_m"] < 2.0
    assert np.max(np.abs(d.col("lane_offset_m"))) < 3.5


def test_a_log_far_from_every_route_measures_from_its_first_pose(tmp_path: Path) -> None:
    # 200 m straight at 30 degrees, starting 2 km from the Countryside task's start and roads:
    # the straight line through the first position along the first heading is the reference
    s = np.arange(0.0, 200.0, 0.5)
    xz = np.column_stack([2000.0 - s * math.sin(0.5), 2000.0 - s * math.cos(0.5)])
    d = load_drive(write_log(tmp_path / "carData.txt", xz), task=TASK)
    assert d.analysis["guide"]["kind"] == "start_line"
    assert np.max(np.abs(d.col("lateral_m"))) < 1e-2
    assert d.col("s_m")[-1] == pytest.approx(199.5, abs=1e-2)


def test_a_log_against_a_route_measures_left_of_its_own_travel(tmp_path: Path) -> None:
    # driving car1a's route backwards, 1 m to the left of the car's own travel direction
    route = route_polylines(load_task(TASK))["vehicle car1a"][::-1][:300]
    d = np.gradient(route, axis=0)
    left = np.column_stack([d[:, 1], -d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]  # (dz, -dx): left of travel
    drive = load_drive(write_log(tmp_path / "carData.txt", route + left), task=TASK)
    assert drive.analysis["guide"]["route"] == "vehicle car1a"
    assert np.median(drive.col("lateral_m")) == pytest.approx(1.0, abs=0.05)
    assert np.all(np.diff(drive.col("s_m")) >= -1e-6)  # distance along grows with travel
