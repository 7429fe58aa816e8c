"""The wheel works on its own, outside the repository: the README's rule, PPO, train and
drive commands find the tasks, policies, configs and DBC it carries.

The wheel is built once from a copy of the package's source files (so no build output lands
in the repository) and installed without dependencies into a folder that goes first on
PYTHONPATH; the test environment supplies the dependencies. Every command runs in a folder
with no repository around it.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "opends_gym", "tasks", "agents", "configs")


class Installed:
    def __init__(self, wheel: Path, site: Path, cwd: Path) -> None:
        self.wheel, self.site, self.cwd = wheel, site, cwd
        self.env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"PYTHONPATH": str(site)}

    def run(self, *argv: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [str(self.site / "bin" / "opends-gym"), *argv], cwd=self.cwd, env=self.env, capture_output=True, text=True, timeout=timeout
        )


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    skip = shutil.ignore_patterns("__pycache__", "runs", "*.egg-info")
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, symlinks=True, ignore=skip)
        else:
            shutil.copy2(path, src / name)
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "wheel", str(src), "--no-deps", "--no-build-isolation", "-w", str(tmp / "dist")], check=True, cwd=tmp)
    (wheel,) = (tmp / "dist").glob("opends_gym-*.whl")
    site = tmp / "site"
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], check=True, cwd=tmp)
    cwd = tmp / "elsewhere"
    cwd.mkdir()
    return Installed(wheel, site, cwd)


def test_wheel_carries_tasks_policies_configs_and_dbc(installed: Installed) -> None:
    names = set(zipfile.ZipFile(installed.wheel).namelist())
    for task in (ROOT / "tasks").iterdir():
        if task.is_dir():
            for f in task.glob("*.xml"):
                assert f"opends_gym/bundled_tasks/{task.name}/{f.name}" in names
    for policy in (ROOT / "agents" / "policies").iterdir():
        if policy.is_dir():
            for f in policy.iterdir():
                assert f"opends_gym/bundled_policies/{policy.name}/{f.name}" in names
    for f in (ROOT / "configs").rglob("*"):
        if f.is_file():
            assert f"opends_gym/bundled_configs/{f.relative_to(ROOT / 'configs').as_posix()}" in names


def test_installed_package_is_the_wheel(installed: Installed) -> None:
    code = "import opends_gym, sys; print(opends_gym.__file__)"
    out = subprocess.run([sys.executable, "-c", code], cwd=installed.cwd, env=installed.env, capture_output=True, text=True, check=True)
    assert Path(out.stdout.strip()).is_relative_to(installed.site)


def test_rule_driver_runs_the_lane_change_test(installed: Installed) -> None:
    r = installed.run("run", "OpenDS/LaneChangeTest-v0", "--agent", "rule", "--episodes", "1", "--json")
    assert r.returncode == 0, r.stderr
    episode = json.loads(r.stdout)["episodes"][0]
    assert episode["lane_changes_correct"] == 18  # the whole bundled task, every sign answered


def test_bundled_ppo_policy_by_name(installed: Installed) -> None:
    r = installed.run("run", "OpenDS/LaneChangeTest-v0", "--agent", "ppo:lct", "--max-seconds", "3", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["episodes"][0]["distance_m"] > 30


def test_list_and_train_a_bundled_config_by_name(installed: Installed) -> None:
    r = installed.run("list", "--configs", "--policies")
    assert r.returncode == 0 and "lct_ppo" in r.stdout and "wheel_calibration" not in r.stdout, r.stdout + r.stderr
    r = installed.run("train", "lct_ppo", "--total-steps", "64", "--no-progress", "--set", "n_envs=1", "--set", "eval_episodes=1")
    assert r.returncode == 0, r.stderr
    run_dir = installed.cwd / "runs" / "lct_ppo"  # a bundled config writes under the current folder
    assert (run_dir / "model.zip").is_file() and json.loads((run_dir / "metrics.json").read_text())["total_steps"] >= 64


def test_drive_over_a_can_bus_with_the_shipped_dbc(installed: Installed) -> None:
    argv = ["drive", "LaneChangeTest", "--input", "can-bus:virtual:wheel-test", "--no-window", "--fast", "--duration", "0.5"]
    r = installed.run(*argv, "--no-audio", "--no-settings-server", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["sim_time_s"] == pytest.approx(0.5, abs=0.05)
