"""A study never ends a drive early on leaving the road: with `on_road_exit: recover` (the
studies' default) a driver that leaves the road is put back and drives on, so every LCT
trial reaches every sign and the resets are counted in the table (exposure, not survival);
the participant's glance metrics reach the table beside the ISO 26022 scores."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from opends_gym.cli.main import main

STUDY = """\
name: exits
seed: 4
participants: 3
on_road_exit: recover
tasks:
  lct:  # a short track whose road edge is 0.6 m outside the outer lanes' centres: weaving leaves it
    env: LaneChangeTest
    env_args: {scoring: iso26022, signs: 5, off_road_margin_m: -1.3}
    metrics: [signs_reached, iso_signs_scored, road_exits, resets, glance_count]
conditions:
  baseline: {load: baseline}
  visual_manual: {load: visual_manual}
power: {simulations: 50, max_n: 20}
bootstrap: 50
"""


def test_no_lct_trial_ends_early_off_the_road_and_resets_are_counted(tmp_path: Path) -> None:
    import gymnasium as gym

    from opends_gym.envs.registration import register_envs

    register_envs()
    signs = len(gym.make("OpenDS/LaneChangeTest-v0", signs=5).unwrapped.metric_signs)
    study = tmp_path / "study.yaml"
    study.write_text(STUDY, encoding="utf-8")
    assert main(["study", str(study), "--out", str(tmp_path / "o"), "--workers", "1", "--no-progress"]) == 0
    table = pd.read_csv(tmp_path / "o" / "table.csv").pivot_table(index=["participant", "condition"], columns="metric", values="value")
    assert len(table) == 3 * 2 and signs == 5
    assert (table["signs_reached"] == signs).all()  # every trial drove the whole track
    assert (table["iso_signs_scored"] == signs).all()
    assert table["road_exits"].sum() >= 1  # the visual-manual load took the car off the road ...
    assert (table["resets"] == table["road_exits"]).all()  # ... and each exit was put back, not ended
    glances = table.xs("visual_manual", level="condition")["glance_count"]
    assert (glances > 10).all()  # the participant's off-road glances are study measures
