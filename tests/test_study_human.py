"""`opends-gym study --human`: a scripted person (a CAN gateway driver) drives a two-condition
study beside virtual participants; a crash in the second block loses the first, and `--resume`
finishes the session."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

from opends_gym.cli.main import main
from tests.human_helpers import ReactionTestDriver, ScriptedGateway, wait_for

ROOT = Path(__file__).resolve().parent.parent
STUDY = """\
name: reaction
seed: 5
participants: 3
tasks:
  reaction:
    env: ReactionTest
    max_seconds: 12
    metrics: [mean_speed_kmh, mean_abs_lateral_offset_m]
conditions:
  baseline: {agent: "distracted:none", instructions: "Drive as you normally would."}
  cognitive: {agent: "distracted:heavy", instructions: "Count backwards from 500 in sevens, aloud."}
"""


def test_a_scripted_person_crashes_resumes_and_joins_the_virtual_participants(tmp_path: Path) -> None:
    study = tmp_path / "study.yaml"
    study.write_text(STUDY, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["study", str(study), "--out", str(out), "--no-progress"]) == 0
    blocks = out / "human" / "P02" / "blocks"
    gw = ScriptedGateway(ReactionTestDriver())
    human = ["study", str(study), "--out", str(out), "--human", "P02", "--input", f"can-tcp:127.0.0.1:{gw.port}", "--no-window", "--fast"]
    try:
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        proc = subprocess.Popen([sys.executable, "-m", "opends_gym.cli.main", *human], cwd=tmp_path, env=env, stdout=subprocess.DEVNULL)
        try:  # crash (SIGKILL) in the middle of the second block
            wait_for(lambda: len(list(blocks.glob("*.csv"))) == 1 and gw.connections == 2, timeout_s=120.0)
            first = len(gw.feedback)
            wait_for(lambda: len(gw.feedback) > first + 40, timeout_s=60.0)
        finally:
            proc.kill()
            proc.wait()
        assert [p.name for p in sorted(blocks.glob("*.csv"))] == ["01-cognitive-reaction-0.csv"]  # P02: row 2 of the square
        assert main(human) == 2  # a second start must not mix two sessions
        assert main([*human, "--resume"]) == 0
    finally:
        gw.close()
    assert gw.connections == 3  # the finished block was not driven again
    assert [p.name for p in sorted(blocks.glob("*.csv"))] == ["01-cognitive-reaction-0.csv", "02-baseline-reaction-0.csv"]
    recordings = sorted(p.name for p in (out / "human" / "P02" / "recordings").glob("*.mcap"))
    # one recording per block; the crashed attempt's kept aside
    assert recordings == ["01-cognitive-reaction-0.mcap", "02-baseline-reaction-0.incomplete-1.mcap", "02-baseline-reaction-0.mcap"]
    table = pd.read_csv(out / "table.csv")
    assert pd.read_parquet(out / "table.parquet").shape == table.shape
    person = table[table.source == "human"]
    assert set(person.participant) == {"P02"} and set(person.condition) == {"baseline", "cognitive"}
    assert len(person) == 2 * 2  # conditions x metrics
    assert set(table[table.source == "virtual"].participant) == {"V001", "V002", "V003"}
    speed = person[person.metric == "mean_speed_kmh"]["value"]
    assert (speed > 20.0).all()  # the scripted driver drove the car in both blocks
