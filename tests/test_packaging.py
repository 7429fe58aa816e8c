"""Shipped files by name and optional extras, through the `opends-gym` command line.

The policies in agents/policies and the configs in configs/ ship inside the package and are
addressed by name (`--agent ppo:lct`, `opends-gym train lct_ppo`, the default CAN DBC, the
calibration example); a feature whose extra is missing says in one line which `pip install`
to run and exits 2.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from opends_gym.cli.main import main as cli
from opends_gym.human.inputs.calibration import load_calibration

ROOT = Path(__file__).resolve().parent.parent
POLICIES = sorted(d.name for d in (ROOT / "agents" / "policies").iterdir() if (d / "model.zip").is_file())
CONFIGS = sorted(p.stem for p in (ROOT / "configs").glob("*.yaml") if "env:" in p.read_text(encoding="utf-8"))


def _one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def _list(capsys: pytest.CaptureFixture[str], *flags: str) -> list[str]:
    assert cli(["list", *flags]) == 0
    return [line.strip() for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]


def test_list_shows_every_shipped_policy_and_training_config(capsys: pytest.CaptureFixture[str]) -> None:
    assert POLICIES and CONFIGS
    assert _list(capsys, "--policies") == POLICIES
    assert _list(capsys, "--configs") == CONFIGS  # the calibration example is no training config
    everything = _list(capsys)
    assert set(POLICIES) | set(CONFIGS) <= set(everything) and "OpenDS/LaneChangeTest-v0" in everything


def _run_json(capsys: pytest.CaptureFixture[str], agent: str) -> dict[str, object]:
    assert cli(["run", "LaneChangeTest", "--agent", agent, "--max-seconds", "4", "--json"]) == 0
    episode = json.loads(capsys.readouterr().out)["episodes"][0]
    return {k: v for k, v in episode.items() if k != "wall_s"}


def test_bundled_policy_by_short_and_full_name_is_the_shipped_model(capsys: pytest.CaptureFixture[str]) -> None:
    by_path = _run_json(capsys, f"ppo:{ROOT / 'agents' / 'policies' / 'lct_ppo' / 'model.zip'}")
    assert _run_json(capsys, "ppo:lct") == by_path
    assert _run_json(capsys, "ppo:lct_ppo") == by_path
    assert by_path["distance_m"] > 50  # it drove


def test_sac_name_resolves_too(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run_json(capsys, "sac:lct") == _run_json(capsys, f"sac:{ROOT / 'agents' / 'policies' / 'lct_sac'}")


@pytest.mark.parametrize(
    ("agent", "expected"),
    [
        ("ppo:lct_sac", "use --agent sac:lct_sac"),  # trained with another algorithm
        ("ppo:no_such_policy", "bundled: brake_ppo, lct_ppo, platoon_ppo"),
        ("sac:brake", "no bundled sac policy named 'brake'"),
    ],
)
def test_unknown_or_mismatched_policy_is_one_line(capsys: pytest.CaptureFixture[str], agent: str, expected: str) -> None:
    assert cli(["run", "LaneChangeTest", "--agent", agent, "--max-seconds", "1"]) == 2
    assert expected in _one_line_error(capsys)


def test_train_unknown_config_name_lists_the_bundled_ones(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert cli(["train", "lct_ppq", "--output", str(tmp_path)]) == 2
    err = _one_line_error(capsys)
    assert "no bundled config named 'lct_ppq'" in err and ", ".join(CONFIGS) in err


def test_calibration_example_loads_by_name() -> None:
    assert load_calibration("wheel_calibration") == load_calibration(ROOT / "configs" / "wheel_calibration.yaml")


def test_drive_with_can_bus_decodes_with_the_shipped_dbc_by_default(capsys: pytest.CaptureFixture[str]) -> None:
    """No --dbc: the session opens the bus with the example DBC (a missing DBC would exit 2)."""
    args = ["drive", "LaneChangeTest", "--input", "can-bus:virtual:pkg-default-dbc", "--no-window", "--fast"]
    assert cli([*args, "--duration", "0.5", "--no-audio", "--no-settings-server", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["sim_time_s"] == pytest.approx(0.5, abs=0.05)


# ---------------------------------------------------------------------- missing extras
# each command with the module its extra provides hidden (None in sys.modules makes the import fail)
MISSING = [
    ("rl", "stable_baselines3", ["run", "LaneChangeTest", "--agent", "ppo:lct", "--max-seconds", "1"]),
    ("rl", "stable_baselines3", ["train", "lct_ppo", "--total-steps", "64"]),
    ("bullet", "pybullet", ["run", "LaneChangeTest", "--physics", "bullet", "--max-seconds", "1"]),
    ("cluster", "ray", ["train", "rllib_ppo", "--total-steps", "64"]),
    ("data", "minari", ["export", "missing.mcap", "--minari", "test/x"]),
    ("data", "minari", ["train", "bc", "test/x-v0"]),
    ("can", "cantools", ["drive", "--input", "can-bus:virtual:pkg-missing", "--no-window", "--fast", "--duration", "0.2"]),
]


@pytest.mark.parametrize(("extra", "module", "argv"), MISSING, ids=[f"{e}-{m}-{a[0]}" for e, m, a in MISSING])
def test_missing_extra_is_one_line_naming_the_pip_command(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path, extra: str, module: str, argv: list[str]
) -> None:
    monkeypatch.chdir(tmp_path)  # a train that did start would write here
    monkeypatch.setitem(sys.modules, module, None)
    assert cli(argv) == 2
    err = _one_line_error(capsys)
    assert re.match(r"opends-gym \w+: error: ", err) and err.endswith(f"needs the '{extra}' extra: pip install \"opends-gym[{extra}]\""), (
        err
    )
    assert not (tmp_path / "runs").exists()


def test_missing_report_extra_is_one_line(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    rec = tmp_path / "d.mcap"
    assert cli(["run", "LaneChangeTest", "--max-seconds", "2", "--record", str(rec)]) == 0
    capsys.readouterr()
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.delitem(sys.modules, "opends_gym.record.report", raising=False)
    assert cli(["analyze", str(rec), "--report", str(tmp_path / "r.pdf")]) == 2
    assert (
        _one_line_error(capsys)
        == "opends-gym analyze: error: the analyzer's PDF report needs the 'report' extra: pip install \"opends-gym[report]\""
    )
    assert not (tmp_path / "r.pdf").exists()
