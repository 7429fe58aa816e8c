"""OpenDS interchange and the analyzer's outputs.

carData.txt fixtures in the real layouts (classic 4.x/CTS with reactionData.xml and
drivingTaskLog.txt beside it, 2023, Oculus Rift, batheja fork) parse to the right values;
the writers round-trip; an MCAP drive exported to OpenDS files analyses the same; the
CLI writes CSV, JSON and a PDF whose pages are the ones expected.
"""

from __future__ import annotations

import csv
import datetime as dt
import json
import logging
import math
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401
from opends_gym.cli.main import main
from opends_gym.record import RecordDrive
from opends_gym.record.analyze import analyze
from opends_gym.record.cardata import read_cardata, write_cardata
from opends_gym.record.drive import load_drive
from opends_gym.record.export import export_opends
from opends_gym.record.opends_logs import read_driving_task_log, read_reaction_data, write_driving_task_log, write_reaction_data
from opends_gym.record.report import write_report

FIX = Path(__file__).parent / "fixtures" / "opends_analyzer"


def jme_yaw(qx: float, qy: float, qz: float, qw: float) -> float:
    return math.atan2(2 * qy * qw - 2 * qx * qz, qx * qx - qy * qy - qz * qz + qw * qw)


def test_classic_cardata_layout() -> None:
    cd = read_cardata(FIX / "classic" / "carData.txt")
    assert (cd.variant, cd.n, cd.driver, cd.created) == ("classic", 10, "default driver", "2016_05_12-14_03_21")
    assert cd.driving_task == "assets/DrivingTasks/Projects/ReactionTest/reactionTest.xml"
    c = cd.columns
    assert c["epoch_ms"][0] == 1463054601234 and c["x_m"][3] == -0.012 and c["z_m"][1] == 24499.98
    assert c["speed_kmh"][4] == 6.48 and c["steering"][7] == -0.02 and c["gas"][4] == 0.8 and c["brake"][9] == 1.0
    assert c["qy"][7] == 1e-4  # Java's "1.0E-4"
    assert list(c["engine_on"][-2:]) == [1.0, 0.0]
    assert cd.t_s()[1] == pytest.approx(0.05) and cd.t_s()[2] == pytest.approx(0.101)


def test_2023_oculus_and_batheja_layouts() -> None:
    cd = read_cardata(FIX / "opends2023" / "carData.txt")
    assert cd.variant == "2023" and cd.n == 3 and cd.created == "2023-03-01 10:15:42.123"
    assert cd.timestamps[0] == "2023-03-01 10.15.42.150"
    assert cd.reference_objects == ["[]", "[car1:17.5:2.0]", "[car1:16.9:1.9; car2:40.0:0.0]"]
    assert cd.columns["z_m"][0] == -40.250004 and cd.columns["front_x_m"][1] == 10.2 and cd.columns["front_z_m"][2] == -42.86
    assert cd.columns["steering"][0] == -0.125 and cd.columns["brake"][2] == 0.2
    d = load_drive(FIX / "opends2023" / "carData.txt")
    assert d.col("yaw_rad")[0] == pytest.approx(math.pi / 4, abs=1e-6)
    oc = read_cardata(FIX / "oculus" / "carData.txt")
    assert oc.variant == "oculus" and list(oc.columns["head_yaw_deg"]) == [12.5, -7.0] and oc.columns["head_pitch_deg"][0] == -3.25
    bj = read_cardata(FIX / "batheja" / "carData.txt")
    assert bj.variant == "batheja" and list(bj.columns["headway_s"]) == [1.76, 1.745, 0.0]
    d = load_drive(FIX / "batheja" / "carData.txt")
    assert list(d.col("headway_s")) == [1.76, 1.745, math.inf]  # OpenDS writes 0 without a lead
    assert list(d.col("ttc_s")) == [4.1, 3.9, math.inf] and d.col("lead_gap_m")[0] == 35.2


def test_classic_folder_with_reaction_data_and_task_log(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="opends_gym.record"):
        d = load_drive(FIX / "classic" / "carData.txt", task="ReactionTest")
    assert any("repaired malformed XML" in r.message for r in caplog.records)  # OpenDS leaves '&' unescaped
    assert d.source == "cardata" and d.meta["task_name"] == "reactionTest"
    c = d.columns
    q = [c[k][4] for k in ("qx", "qy", "qz", "qw")]
    assert c["yaw_rad"][4] == pytest.approx(jme_yaw(*q)) and c["yaw_rad"][4] == pytest.approx(-0.0348, abs=1e-4)
    assert len(d.analysis["lanes"]) == 5 and d.analysis["guide"]["kind"] == "lanes"
    assert c["lateral_m"][6] == pytest.approx(0.09) and c["lane_index"][6] == 2  # -x in the centre lane
    assert [(r["group"], r["result"], r["reaction_time_s"]) for r in d.reactions] == [("Brake", 1, 0.812), ("LaneChange", -2, 10.0)]
    assert d.reactions[0]["t_s"] == pytest.approx(0.3) and d.reactions[0]["comment"] == "BLC_Test_Block1_Trial1_Brake"
    local = dt.datetime(2016, 5, 12, 14, 3, 21, 534000).timestamp() * 1000
    log_event = next(e for e in d.events if "reaction time at" in e["params"]["text"])
    assert log_event["t_s"] == pytest.approx((local - 1463054601234) / 1000)
    a = analyze(d)
    assert a.groups["Brake"]["mean_rt_s"] == 0.812 and a.groups["LaneChange"]["misses"] == 1
    assert a.summary["duration_s"] == pytest.approx(0.451) and a.summary["distance_m"] > 0.7


def test_cardata_without_its_task_measures_from_the_start_line() -> None:
    d = load_drive(FIX / "classic" / "carData.txt")
    assert any("driving task not found" in n for n in d.notes)
    assert d.analysis["guide"]["kind"] == "start_line" and d.col("lateral_m")[6] == pytest.approx(0.09)


def test_malformed_and_torn_rows(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    lines = (FIX / "classic" / "carData.txt").read_text().splitlines()
    bad = tmp_path / "bad.txt"
    bad.write_text("\n".join(lines[:6] + ["1463054601300:0.0:oops:1:0:0:0:1:0:0:0:0:true"] + lines[6:]) + "\n")
    with pytest.raises(ValueError, match=r"bad\.txt:7: could not convert"):
        read_cardata(bad)
    torn = tmp_path / "torn.txt"
    torn.write_text("\n".join(lines) + "\n1463054601735:0.0:0.52")
    with caplog.at_level(logging.WARNING, logger="opends_gym"):
        assert read_cardata(torn).n == 10
    assert "torn last row" in caplog.text


def test_cardata_writer_round_trip_at_20_hz(tmp_path: Path) -> None:
    t = np.arange(0, 181) / 60.0  # 3 s at 60 Hz
    x, z = 0.1234567 * t, -16.6666666 * t
    q = np.column_stack([np.zeros_like(t), np.sin(0.1 * t), np.zeros_like(t), np.cos(0.1 * t)])
    p = write_cardata(
        tmp_path / "carData.txt",
        t,
        x,
        0.5 * np.ones_like(t),
        z,
        q,
        60.0 * np.ones_like(t),
        -0.1234567 * np.ones_like(t),
        np.ones_like(t),
        np.zeros_like(t),
        np.ones_like(t, dtype=bool),
        driving_task="tasks/x.xml",
        driver="P1",
        start_epoch_ms=1_700_000_000_000,
    )
    cd = read_cardata(p)
    assert cd.variant == "classic" and cd.driver == "P1" and cd.driving_task == "tasks/x.xml"
    assert cd.n == 61  # one row per 50 ms slot, as OpenDS's 20 Hz writer
    assert np.allclose(cd.t_s(), np.round(t[::3] * 1000) / 1000)
    assert cd.columns["x_m"][10] == round(x[30], 3) and cd.columns["z_m"][60] == round(z[180], 3)
    assert cd.columns["qy"][20] == round(q[60, 1], 4) and cd.columns["steering"][0] == -0.12346
    assert cd.columns["epoch_ms"][1] == 1_700_000_000_050 and cd.columns["engine_on"].all()


def test_reaction_data_and_task_log_round_trip(tmp_path: Path) -> None:
    reactions = [
        {
            "timer_id": "t1",
            "group": "Brake",
            "result": 1,
            "reaction_time_s": 0.6531,
            "t_s": 12.5,
            "experiment_time_s": 10.0,
            "comment": "a<b & c",
        },
        {
            "timer_id": "t2",
            "group": "LaneChange",
            "result": -2,
            "reaction_time_s": 10.0,
            "t_s": 30.0,
            "experiment_time_s": 27.5,
            "comment": "",
        },
    ]
    p = write_reaction_data(tmp_path / "reactionData.xml", reactions, start_epoch_ms=1_000_000)
    back = read_reaction_data(p)
    assert [(r["group"], r["result"], r["reaction_time_s"], r["absolute_ms"], r["experiment_time_s"], r["comment"]) for r in back] == [
        ("Brake", 1, 0.653, 1_012_500, 10.0, "a<b & c"),
        ("LaneChange", -2, 10.0, 1_030_000, 27.5, ""),
    ]
    events = [
        {"t_s": 5.0, "kind": "report", "source": "trig", "params": {"text": "lap 1"}},
        {"t_s": 7.25, "kind": "measurement", "source": "stopwatch", "params": {"elapsed_s": 61.5}},
    ]
    log = write_driving_task_log(
        tmp_path / "drivingTaskLog.txt", events, reactions, driver="P9", driving_task="t.xml", start_epoch_ms=1_000_000
    )
    header, entries = read_driving_task_log(log)
    assert header["Driver"] == "P9" and header["Driving Task"] == "t.xml"
    assert [(e - 1_000_000, text) for e, text in entries[:2]] == [(5000, "lap 1"), (7250, "reaction time at 'stopwatch': 01:01.500")]
    assert entries[2][1].startswith("reaction Brake 't1': correct, reaction time 00:00.653")
    assert "missed" in entries[3][1]


@pytest.fixture(scope="module")
def reaction_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "drive.mcap"
    env = RecordDrive(gym.make("OpenDS/ReactionTest-v0", max_episode_s=40.0), path)
    env.reset(seed=0)
    while True:
        *_, terminated, truncated, _ = env.step(np.array([0.0, 1.0], dtype=np.float32))
        if terminated or truncated:
            break
    env.close()
    return env.paths[0]


def test_mcap_exported_to_opends_files_analyses_the_same(reaction_recording: Path, tmp_path: Path) -> None:
    drive = load_drive(reaction_recording)
    written = export_opends(drive, tmp_path / "analyzerData")
    assert [p.name for p in written] == ["carData.txt", "reactionData.xml", "drivingTaskLog.txt"]
    with pytest.raises(FileExistsError):
        export_opends(drive, tmp_path / "analyzerData")
    back = load_drive(tmp_path / "analyzerData" / "carData.txt")  # the task path in its header is found again
    assert back.meta["task_name"] == "reactionTest" and back.analysis["guide"]["kind"] == "lanes"
    a, b = analyze(drive), analyze(back)
    assert b.summary["duration_s"] == pytest.approx(a.summary["duration_s"], abs=0.05)
    assert b.summary["distance_m"] == pytest.approx(a.summary["distance_m"], rel=0.01)
    assert b.summary["mean_speed_kmh"] == pytest.approx(a.summary["mean_speed_kmh"], rel=0.01)
    assert [(r["group"], r["result"]) for r in back.reactions] == [(r["group"], r["result"]) for r in drive.reactions]
    t0 = drive.col("t_s")[0]  # carData time starts at its first row (the first physics step)
    assert [r["t_s"] for r in back.reactions] == pytest.approx([r["t_s"] - t0 for r in drive.reactions], abs=1e-3)


def pdf_pages(path: Path) -> int:
    return len(re.findall(rb"/Type\s*/Page\b", path.read_bytes()))


def test_report_pdf_has_the_expected_pages(tmp_path: Path) -> None:
    from tests.test_analyze import synthetic, with_track

    dist = np.arange(-5.0, 105.0, 0.5)
    d = with_track(synthetic(0.02 * dist, -dist, speed_kmh=np.full(len(dist), 50.0)), [(0.0, -10.0 * k) for k in range(11)])
    d.reactions = [
        {"timer_id": "b", "group": "Brake", "result": 1, "reaction_time_s": 0.7, "t_s": 1.0},
        {"timer_id": "l", "group": "Lane", "result": -2, "reaction_time_s": 10.0, "t_s": 2.0},
    ]
    d.analysis["reaction_groups"] = {"Brake": "red", "Lane": "green"}
    pages = write_report(analyze(d), tmp_path / "r.pdf")
    assert pages == ["summary", "reactions", "path", "timeseries"]
    data = (tmp_path / "r.pdf").read_bytes()
    assert data.startswith(b"%PDF") and pdf_pages(tmp_path / "r.pdf") == 4
    for k, name in enumerate(pages, start=1):
        png = tmp_path / f"r_{k}_{name}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_analyze_csv_json_report(reaction_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pdf, out = tmp_path / "r.pdf", tmp_path / "samples.csv"
    assert main(["analyze", str(reaction_recording), "--csv", str(out), "--report", str(pdf), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["source"] == "mcap" and result["complete"] and result["summary"]["duration_s"] == pytest.approx(40.0 - 1 / 60)
    assert result["parameters"]["srr_gap_deg"] == 2.0 and set(result["reaction_groups"]) >= {"Brake"}
    assert result["reactions"] and result["lateral"]["sdlp_m"] is not None
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2400 and float(rows[0]["t_s"]) == pytest.approx(1 / 60) and "lane_offset_m" in rows[0]
    with open(tmp_path / "samples_metrics.csv") as f:
        metrics = {(r["section"], r["measure"]): r["value"] for r in csv.DictReader(f)}
    assert float(metrics[("drive", "duration_s")]) == pytest.approx(40.0 - 1 / 60)
    assert (tmp_path / "samples_reactions.csv").is_file()
    n = pdf_pages(pdf)
    assert pdf.read_bytes().startswith(b"%PDF") and n == 4  # summary, reactions, path, time series
    assert main(["analyze", str(FIX / "classic" / "carData.txt"), "--task", "ReactionTest"]) == 0
    text = capsys.readouterr().out
    assert "[reactions Brake]" in text and "cardata" in text
    assert main(["analyze", str(tmp_path / "nope.mcap")]) == 2
