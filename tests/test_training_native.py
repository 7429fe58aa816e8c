"""PPO on the native batch (`vec_env: native`): runs learn, save in the bundled policy
format, drive through `--agent`, stop at a quality bar, and repeat for a seed."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import opends_gym  # noqa: F401
from opends_gym.cli.main import main as cli
from opends_gym.training import load_train_config
from opends_gym.training.native_ppo import gae, train

SHORT = {"signs": 3, "lead_in_m": 100, "lead_out_m": 100, "policy_hz": 5, "max_episode_s": 60}
QUICK = f"""
env: OpenDS/LaneChangeTest-v0
env_kwargs: {json.dumps(SHORT)}
vec_env: native
total_steps: 40960
n_envs: 64
policy_kwargs: {{net_arch: [32, 32], log_std_init: -3.0}}
hyperparameters: {{n_steps: 32, batch_size: 1024, n_epochs: 5, learning_rate: 0.001}}
checkpoint_every_steps: 20480
eval_every_steps: 20480
eval_episodes: 1
progress_bar: false
"""


def _config(tmp: Path, text: str = QUICK, **overrides: object) -> tuple:
    (tmp / "quick.yaml").write_text(text, encoding="utf-8")
    return load_train_config(tmp / "quick.yaml", dict(overrides))


@pytest.fixture(scope="module")
def native_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("native")
    cfg, base = _config(folder)
    train(cfg, base, folder / "run")
    return folder / "run"


def test_native_run_learns_and_writes_the_bundled_format(native_run: Path) -> None:
    rows = list(csv.DictReader((native_run / "curve.csv").open(encoding="utf-8")))
    returns = [float(r["mean_return_last_10"]) for r in rows]
    assert len(rows) == 40960 // (64 * 32)
    assert np.mean(returns[-3:]) > np.mean(returns[:3]) + 1.0  # (a random start scores ~-9: it leaves the road)
    for name in ("model.zip", "model.vecnormalize.pkl", "evaluations.npz", "metrics.json"):
        assert (native_run / name).is_file(), name
    assert (native_run / "checkpoints" / "model_20480_steps.zip").is_file()
    assert (native_run / "checkpoints" / "model_vecnormalize_20480_steps.pkl").is_file()
    metrics = json.loads((native_run / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["total_steps"] == 40960 and "mdev_basic_m" in metrics["mean"]
    from stable_baselines3 import PPO

    assert PPO.load(str(native_run / "model.zip")).num_timesteps == 40960


def test_native_policy_drives_through_the_cli(native_run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["run", "OpenDS/LaneChangeTest-v0", "--agent", f"ppo:{native_run / 'model.zip'}", "--json", "--episodes", "1", "--seed", "1000"]
    for key, value in SHORT.items():
        args += ["--env-arg", f"{key}={value}"]
    assert cli(args) == 0
    episode = json.loads(capsys.readouterr().out)["episodes"][0]
    final = json.loads((native_run / "metrics.json").read_text(encoding="utf-8"))["episodes"][0]
    assert episode["return"] == pytest.approx(final["return"])  # the trainer's evaluation is the CLI's drive


def test_same_seed_same_run_and_stop_at_ends_it(tmp_path: Path) -> None:
    """Two runs of one config give the same curve; `stop_at` ends a run at the first
    evaluation within bounds, and that checkpoint is the run's model."""
    runs = []
    for name in ("a", "b"):
        cfg, base = _config(tmp_path, total_steps=8192, eval_every_steps=4096, stop_at={"collisions": [0, 0]})
        metrics = train(cfg, base, tmp_path / name)
        runs.append(list(csv.DictReader((tmp_path / name / "curve.csv").open(encoding="utf-8"))))
        assert metrics["stopped_at"] == 4096 and len(runs[-1]) == 2
        assert (tmp_path / name / "model.zip").read_bytes() != b""
    strip = [[{k: v for k, v in r.items() if not k.endswith("_s")} for r in rows] for rows in runs]
    assert strip[0] == strip[1]


def test_native_config_errors_name_the_key(tmp_path: Path) -> None:
    cfg, base = _config(tmp_path, hyperparameters={"n_stepz": 8})
    with pytest.raises(ValueError, match=r"unknown key\(s\) n_stepz for vec_env native"):
        train(cfg, base, tmp_path / "x")
    with pytest.raises(ValueError, match=r"stop_at: collisions needs \[low, high\]"):
        _config(tmp_path, stop_at={"collisions": 0})
    (tmp_path / "bad.yaml").write_text(QUICK.replace("vec_env: native", "vec_env: nativ"), encoding="utf-8")
    assert cli(["train", str(tmp_path / "bad.yaml")]) == 2


def test_advantages_bootstrap_truncation_but_not_termination() -> None:
    """One env, two steps, reward 1 each, values 0.5; the episode ends at the first step."""
    rew = np.ones((2, 1), dtype=np.float32)
    val = np.full((3, 1), 0.5, dtype=np.float32)
    end = np.array([[True], [False]])
    terminated, _ = gae(rew, val, end, end, gamma=0.9, lam=1.0)
    truncated, _ = gae(rew, val, np.zeros_like(end), end, gamma=0.9, lam=1.0)
    assert terminated[0, 0] == pytest.approx(1 - 0.5)  # no value after a terminal step
    assert truncated[0, 0] == pytest.approx(1 + 0.9 * 0.5 - 0.5)  # the last observation's value
    assert terminated[1, 0] == truncated[1, 0] == pytest.approx(1 + 0.9 * 0.5 - 0.5)  # the next episode, not chained back


def test_the_lct_ppo_config_trains_natively_and_on_ray() -> None:
    """`opends-gym train lct_ppo` trains on the native batch until the shipped policy's bar;
    its `rllib:` block is valid, so `--set framework=rllib` runs the same file on Ray."""
    from opends_gym.resources import resolve_config
    from opends_gym.training.native_ppo import NativePpoSettings
    from opends_gym.training.rllib import RllibSettings

    cfg, _ = load_train_config(resolve_config("lct_ppo"), {"framework": "rllib"})
    assert cfg.vec_env == "native" and cfg.stop_at["lane_changes_correct"] == [18, 18]
    NativePpoSettings.from_block("", dict(cfg.hyperparameters))
    settings = RllibSettings.from_block(dict(cfg.rllib))
    assert settings.train_batch_size == cfg.n_envs * cfg.hyperparameters["n_steps"]


def test_a_native_run_resumes_with_its_normaliser(native_run: Path, tmp_path: Path) -> None:
    import pickle

    from stable_baselines3 import PPO

    cfg, base = _config(tmp_path, total_steps=2048)
    train(cfg, base, tmp_path / "more", resume=native_run)
    assert PPO.load(str(tmp_path / "more" / "model.zip")).num_timesteps == 40960 + 2048
    with (native_run / "model.vecnormalize.pkl").open("rb") as f:
        before = pickle.load(f).obs_rms.count
    with (tmp_path / "more" / "model.vecnormalize.pkl").open("rb") as f:
        assert pickle.load(f).obs_rms.count > before  # the saved statistics, carried on
    with pytest.raises(ValueError, match="nothing to resume"):
        train(cfg, base, tmp_path / "bad", resume=tmp_path)


BRAKE = {"stimuli": 2, "lead_in_m": 100, "lead_out_m": 100, "policy_hz": 5}
WARM = f"""
env: OpenDS/BrakeReaction-v0
env_kwargs: {json.dumps(BRAKE)}
vec_env: native
total_steps: 1024
n_envs: 16
policy_kwargs: {{net_arch: [32, 32]}}
warm_start: {{episodes: 2, dagger: 2, epochs: 20, noise: [0.01, 0.1], log_std: [-4.6, -2.3]}}
hyperparameters: {{n_steps: 32, batch_size: 256, n_epochs: 2, value_warmup: 2}}
checkpoint_every_steps: 512
eval_every_steps: 512
eval_episodes: 1
progress_bar: false
"""


def test_a_warm_start_clones_the_rule_driver_and_value_warmup_keeps_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`warm_start:` clones the rule driver before PPO (the curve's row at step 0 scores the
    clone); during `value_warmup` rollouts only the value function learns, so the policy
    drives as the clone did; the clone answers the brake test's stimuli as the driver does."""
    cfg, base = _config(tmp_path, WARM)
    metrics = train(cfg, base, tmp_path / "run")
    rows = list(csv.DictReader((tmp_path / "run" / "curve.csv").open(encoding="utf-8")))
    assert [int(r["steps"]) for r in rows] == [0, 512, 1024]
    assert int(rows[0]["warm_start_steps"]) > 100 and float(rows[0]["warm_start_loss"]) < 0.05
    assert len({r["eval_return"] for r in rows}) == 1  # value-only rollouts left the policy alone
    assert rows[0]["eval_stimulus_misses"] == "0.0" and rows[0]["eval_collisions"] == "0.0"
    assert cli(["run", "OpenDS/BrakeReaction-v0", "--agent", "rule", "--json", "--episodes", "1", "--seed", "1000"]
               + [a for k, v in BRAKE.items() for a in ("--env-arg", f"{k}={v}")]) == 0  # fmt: skip
    rule = json.loads(capsys.readouterr().out)["episodes"][0]
    assert metrics["mean"]["stimuli"] == rule["stimuli"] == 2  # (a clone of 1 drive + 1 DAgger round stopped after 300 m)
    assert metrics["mean"]["distance_m"] == pytest.approx(rule["distance_m"], rel=0.05)  # to the end of the track
    from stable_baselines3 import PPO

    log_std = PPO.load(str(tmp_path / "run" / "model.zip")).policy.log_std.detach().numpy()
    assert np.allclose(log_std, [-4.6, -2.3])  # the exploration noise the config set after cloning


def test_warm_start_errors_name_the_key(tmp_path: Path) -> None:
    cfg, base = _config(tmp_path, WARM, warm_start={"episodez": 1})
    with pytest.raises(ValueError, match=r"warm_start: unknown key\(s\) episodez; valid keys: .*episodes"):
        train(cfg, base, tmp_path / "x")
    cfg, base = _config(tmp_path, WARM, warm_start={"noise": -0.1})
    with pytest.raises(ValueError, match="warm_start: noise must be >= 0"):
        train(cfg, base, tmp_path / "y")
    with pytest.raises(ValueError, match=r"quick\.yaml: warm_start needs vec_env native .* not vec_env 'dummy'"):
        _config(tmp_path, WARM, vec_env="dummy")


def test_time_to_quality_plot_draws_the_shipped_native_runs(tmp_path: Path) -> None:
    """agents/plot_time_to_quality.py (docs/training.md's figure) draws one panel per shipped
    native run and names the curve that has no evaluations with training time."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    script = str(root / "agents" / "plot_time_to_quality.py")
    runs = [str(root / "agents" / "policies" / n) for n in ("lct_ppo", "platoon_ppo", "brake_ppo")]
    done = subprocess.run([sys.executable, script, *runs, "--out", str(tmp_path / "t.png")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    from PIL import Image

    with Image.open(tmp_path / "t.png") as img:
        assert img.size[0] >= 3 * 400  # a panel per run
    sb3 = tmp_path / "sb3_run"
    sb3.mkdir()
    (sb3 / "curve.csv").write_text("steps,mean_return_last_10\n8192,1.0\n", encoding="utf-8")
    done = subprocess.run([sys.executable, script, str(sb3), "--out", str(tmp_path / "x.png")], capture_output=True, text=True, timeout=120)
    assert done.returncode != 0 and "sb3_run/curve.csv: no evaluations with train_s" in done.stderr
