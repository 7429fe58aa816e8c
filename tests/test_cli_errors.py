"""Mistakes a user makes on the command line: one line on stderr, exit 2, the name that was meant."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from opends_gym.cli.main import main

from .conftest import ROOT

# (argv, words the one line must hold)
MISTAKES = [
    (["run", "OpenDS/LaneChangTest-v0"], ["unknown env id", "did you mean OpenDS/LaneChangeTest-v0?"]),
    (["run", "LaneChangTest"], ["neither an env id nor a task", "did you mean OpenDS/LaneChangeTest-v0?"]),
    (["run", "no_such_task_folder/"], ["no_such_task_folder/", "no such file or folder"]),
    (["run", "--agent", "foo"], ["unknown agent 'foo'", "rule"]),
    (["run", "--agent", "rnadom"], ["did you mean random?"]),
    (["run", "--agent", "distracted:hevy"], ["unknown distraction level 'hevy'"]),
    (["run", "--agent", "constant:a,b"], ["--agent constant:a,b"]),
    (["run", "--agent", "ppo:no/such/model.zip"], ["no saved policy at 'no/such/model.zip'"]),
    (["run", "--agent", "ppo"], ["give the saved model: ppo:PATH"]),
    (["run", "--agent", f"ppo:{ROOT / 'README.md'}"], ["README.md", "zip"]),
    (["run", "--env-arg", "polcy_hz=20"], ["polcy_hz", "did you mean policy_hz?"]),
    (["run", "OpenDS/DrivingTask-v0", "--env-arg", "task=ReactonTest"], ["ReactonTest", "did you mean ReactionTest?"]),
    (["run", "--env-arg", "policy_hz=fast"], ["policy_hz=fast", "expected a number"]),
    (["run", "--env-arg", "lanes=2.5"], ["lanes=2.5", "expected an integer"]),
    (["run", "--env-arg", "terminate_on_collision=maybe"], ["expected true or false"]),
    (["run", "--env-arg", "policy_hz"], ["expected KEY=VALUE"]),
    (["run", "--env-arg", "physics=bogus"], ["physics must be 'fast' or 'bullet'"]),
    (["run", "--episodes", "0"], ["--episodes must be at least 1"]),
    (["run", "--max-seconds", "-1"], ["--max-seconds: must be a number above 0"]),
    (["run", "--record-rate", "0", "--record", "never.mcap"], ["--record-rate: must be a number above 0"]),
    (["run", "--csv", "no/such/folder/out.csv"], ["--csv", "does not exist"]),
    (["run", "--csv", str(ROOT / "tests")], ["is a folder"]),
    (["run", "--physics", "bulet"], ["invalid choice", "did you mean bullet?"]),
    (["run", "--agnet", "rule"], ["unrecognized arguments: --agnet", "did you mean --agent?"]),
    (["rnu"], ["invalid choice", "did you mean run?"]),
    (["--log-level", "verbose", "list"], ["unknown level 'verbose'"]),
    (["validate", "ReactonTest"], ["ReactonTest", "did you mean ReactionTest?"]),
    (["validate", "--schema-dir", "no/such/xsd", "--strict", "ReactionTest"], ["--schema-dir no/such/xsd"]),
    (["drive", "OpenDS/ConTRe-v1", "--no-window"], ["unknown env id", "did you mean OpenDS/ConTRe-v0?"]),
    (["drive", "--no-window", "--input", "joystik"], ["unknown input 'joystik'"]),
    (["drive", "--no-window", "--calibration", "no/such/wheel.yaml"], ["--calibration no/such/wheel.yaml"]),
    (["drive", "--no-window", "--env-arg", "polcy_hz=20"], ["did you mean policy_hz?"]),
    (["drive", "--no-window", "--duration", "-1"], ["--duration: must be a number above 0"]),
    (["drive", "--no-window", "--server-port", "99999"], ["--server-port: must be a port number"]),
    (["replay", "no/such/drive.mcap"], ["no/such/drive.mcap"]),
    (["analyze", "no/such/carData.txt"], ["no/such/carData.txt"]),
    (["train", "no/such/config.yaml"], ["no/such/config.yaml"]),
    (["list", "--bogus"], ["unrecognized arguments: --bogus"]),
]


def _one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own errors exit from inside parse_args
        code = e.code
    captured = capsys.readouterr()
    assert code == 2, f"{argv}: exit {code}"
    assert captured.err.count("\n") == 1 and captured.err.endswith("\n"), f"{argv}: not one line:\n{captured.err}"
    assert "Traceback" not in captured.err
    return captured.err


@pytest.mark.parametrize(("argv", "words"), MISTAKES, ids=[" ".join(a) for a, _ in MISTAKES])
def test_mistake_is_one_line_and_exit_2(argv: list[str], words: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    err = _one_line_error(capsys, argv)
    for word in words:
        assert word in err, f"{argv}: {word!r} not in {err!r}"


def test_far_off_name_gets_no_suggestion(capsys: pytest.CaptureFixture[str]) -> None:
    assert "did you mean" not in _one_line_error(capsys, ["run", "--agent", "xyzzy"])


def test_missing_extra_names_the_pip_install(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # as if the rl extra were not installed
    err = _one_line_error(capsys, ["run", "--agent", f"ppo:{ROOT / 'README.md'}"])
    assert 'pip install "opends-gym[rl]"' in err


def test_debug_shows_the_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    from opends_gym.errors import UserError

    with pytest.raises(UserError, match="did you mean OpenDS/LaneChangeTest-v0"):
        main(["--debug", "run", "OpenDS/LaneChangTest-v0"])
    with pytest.raises(UserError):  # after the sub-command too
        main(["run", "OpenDS/LaneChangTest-v0", "--debug"])


def test_a_real_task_path_still_runs(capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An env-id-shaped folder that exists is a task, not a misspelt id."""
    import shutil

    from opends_gym.task.bundled import BUNDLED_DIR

    folder = tmp_path / "Lab" / "Brake-v1"
    shutil.copytree(BUNDLED_DIR / "BrakeReaction", folder)
    monkeypatch.chdir(tmp_path)
    assert main(["run", "Lab/Brake-v1", "--max-seconds", "0.5", "--json"]) == 0
    assert '"task": "brakeReaction"' in capsys.readouterr().out


def test_broken_task_is_one_line_naming_file_line_and_element(task_copy, capsys: pytest.CaptureFixture[str]) -> None:
    folder = task_copy("opends-cts/ReactionTest", "scenario.xml", "<xMin>-5.55</xMin>", "<xMin>left</xMin>")
    err = _one_line_error(capsys, ["run", str(folder)])
    assert "scenario.xml:" in err and "<xMin>" in err and "'left'" in err


def test_ctrl_c_is_one_line_and_exit_130(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import opends_gym.drivers.episodes as episodes

    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(episodes, "run_episode", interrupted)
    assert main(["run", "--episodes", "3", "--progress"]) == 130
    err = capsys.readouterr().err
    assert err.endswith("opends-gym run: interrupted\n") and "Traceback" not in err
