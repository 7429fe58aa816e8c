"""Training from configs: SB3 runs improve, save, and load back as agents."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import opends_gym  # noqa: F401
from opends_gym.cli.main import main as cli
from opends_gym.envs import ENVS
from opends_gym.training import load_train_config
from opends_gym.training.sb3 import train

ROOT = Path(__file__).resolve().parent.parent

QUICK = """
env: OpenDS/LaneChangeTest-v0
env_kwargs: {signs: 3, lead_in_m: 100, lead_out_m: 100, policy_hz: 5, max_episode_s: 60}
total_steps: 12000
n_envs: 4
hyperparameters: {n_steps: 256, batch_size: 256, n_epochs: 5, learning_rate: 0.001}
policy_kwargs: {net_arch: [32, 32]}
checkpoint_every_steps: 6000
eval_every_steps: 6000
eval_episodes: 1
progress_bar: false
"""


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("train")
    (folder / "quick.yaml").write_text(QUICK, encoding="utf-8")
    cfg, base = load_train_config(folder / "quick.yaml")
    train(cfg, base, folder / "run")
    return folder / "run"


def test_short_ppo_run_improves_its_return(quick_run: Path) -> None:
    rows = list(csv.DictReader((quick_run / "curve.csv").open(encoding="utf-8")))
    returns = [float(r["mean_return_last_10"]) for r in rows]
    assert len(returns) > 20
    # (+1.3 in 12k steps on OpenDS's car, whose 1 rad full-lock steering a random policy swings wildly)
    assert np.mean(returns[-5:]) > np.mean(returns[:5]) + 1.0
    for name in ("model.zip", "model.vecnormalize.pkl", "evaluations.npz", "metrics.json"):
        assert (quick_run / name).is_file(), name
    assert list((quick_run / "checkpoints").glob("model_*_steps.zip"))
    metrics = json.loads((quick_run / "metrics.json").read_text(encoding="utf-8"))
    assert metrics["mean"]["duration_s"] > 0 and "mdev_basic_m" in metrics["mean"]


def test_saved_policy_runs_through_the_cli(quick_run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["run", "OpenDS/LaneChangeTest-v0", "--agent", f"ppo:{quick_run / 'model.zip'}", "--json", "--episodes", "1"]
    for option in ("signs=3", "lead_in_m=100", "lead_out_m=100", "policy_hz=5", "max_episode_s=60"):
        args += ["--env-arg", option]
    assert cli(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["agent"].startswith("ppo:")
    # the CLI drives the saved policy: the episode of that policy driven in-process (seed 0). How
    # long a 12k-step policy stays on the road is up to its training (this one may leave it within
    # a second: ending the episode costs less than the LCT's penalties over 60 s off the lane)
    from opends_gym.drivers.episodes import run_episode
    from opends_gym.drivers.policy import PolicyDriver

    env = gym.make("OpenDS/LaneChangeTest-v0", signs=3, lead_in_m=100, lead_out_m=100, policy_hz=5, max_episode_s=60)
    direct = run_episode(env, PolicyDriver("ppo", quick_run / "model.zip"), 0)
    env.close()
    episode = out["episodes"][0]
    assert episode["steps"] == direct.steps and episode["return"] == pytest.approx(direct.ret)
    assert episode["steps"] >= 2 and episode["lane_changes_correct"] == direct.metrics["lane_changes_correct"]


def test_a_checkpoint_drives_with_its_own_normaliser(quick_run: Path) -> None:
    """A run stopped early is still usable: `--agent ppo:checkpoints/model_N_steps.zip`
    normalises observations with the statistics saved at that checkpoint."""
    import pickle

    from opends_gym.drivers.policy import PolicyDriver

    checkpoint = quick_run / "checkpoints" / "model_6000_steps.zip"
    driver = PolicyDriver("ppo", checkpoint)
    with (quick_run / "checkpoints" / "model_vecnormalize_6000_steps.pkl").open("rb") as f:
        saved = pickle.load(f).obs_rms
    with (quick_run / "model.vecnormalize.pkl").open("rb") as f:
        final = pickle.load(f).obs_rms
    assert driver.obs_rms is not None and np.array_equal(driver.obs_rms.mean, saved.mean)
    assert not np.array_equal(saved.mean, final.mean)  # the statistics of step 6000, not the final ones


def test_policy_rejects_an_env_with_other_observations(quick_run: Path) -> None:
    from opends_gym.drivers.policy import PolicyDriver

    driver = PolicyDriver("ppo", quick_run / "model.zip")
    with pytest.raises(ValueError, match="expects observations of shape"):
        driver.reset(gym.make("OpenDS/ConTRe-v0"), 0)


def test_config_typos_are_errors_naming_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("env: OpenDS/LaneChangeTest-v0\ntotal_stepz: 10\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"bad\.yaml: unknown key\(s\) total_stepz \(did you mean total_steps\?\)"):
        load_train_config(bad)
    bad.write_text("env: OpenDS/LaneChangeTest-v0\nalgorithm: dqn\n", encoding="utf-8")
    with pytest.raises(ValueError, match="algorithm must be one of"):
        load_train_config(bad)
    assert cli(["train", str(bad)]) == 2
    bad.write_text("env: OpenDS/LaneChangeTest-v0\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"bad\.yaml: stop_at must be a mapping of keys to values, not '18'"):
        load_train_config(bad, {"stop_at": "18"})  # (as `--set stop_at=18` gives it)


def _training_configs() -> list[str]:
    """The YAML files in configs/ that are training configs (they name an env and an algorithm)."""
    out = []
    for p in sorted((ROOT / "configs").glob("*.yaml")):
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
        if isinstance(data, dict) and "env" in data and "algorithm" in data:
            out.append(p.name)
    return out


@pytest.mark.parametrize("name", _training_configs())
def test_shipped_configs_load(name: str) -> None:
    cfg, _ = load_train_config(ROOT / "configs" / name)
    assert cfg.env in ENVS


@pytest.mark.parametrize("env_id", sorted(ENVS))
def test_every_env_trains_with_ppo(env_id: str) -> None:
    from stable_baselines3 import PPO

    env = gym.make(env_id, max_episode_s=20.0)
    model = PPO("MlpPolicy", env, n_steps=512, batch_size=128, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=2048)  # "a few thousand steps", across episode ends
    action, _ = model.predict(env.reset(seed=0)[0], deterministic=True)
    assert env.action_space.contains(action)
    env.close()


def test_a_finished_run_can_be_resumed(quick_run: Path, tmp_path: Path) -> None:
    cfg, base = load_train_config(ROOT / "configs" / "lct_ppo.yaml")
    cfg, _ = load_train_config(quick_run.parent / "quick.yaml", {"total_steps": 2048, "checkpoint_every_steps": 1024})
    train(cfg, base, tmp_path / "more", resume=quick_run)
    rows = list(csv.DictReader((tmp_path / "more" / "curve.csv").open(encoding="utf-8")))
    assert int(rows[0]["steps"]) > 12000  # the curve continues from the first run's steps
    from stable_baselines3 import PPO

    assert PPO.load(str(tmp_path / "more" / "model.zip")).num_timesteps >= 12000 + 2048
    with pytest.raises(ValueError, match="nothing to resume"):
        train(cfg, base, tmp_path / "bad", resume=tmp_path)


def test_plot_curves_draws_every_shipped_policy(tmp_path: Path) -> None:
    """agents/plot_curves.py turns the run folders' curve.csv and evaluations into one PNG panel each."""
    import subprocess
    import sys

    out = tmp_path / "curves.png"
    script = str(ROOT / "agents" / "plot_curves.py")
    done = subprocess.run([sys.executable, script, "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    shipped = [d for d in (ROOT / "agents" / "policies").iterdir() if (d / "curve.csv").is_file()]
    assert len(shipped) >= 2
    from PIL import Image

    with Image.open(out) as img:
        width, height = img.size
        assert width >= 400 * len(shipped) and height >= 300  # one panel per policy
    broken = tmp_path / "runs" / "empty_run"
    broken.mkdir(parents=True)
    (broken / "curve.csv").write_text("steps,mean_return_last_10\n")
    args = [sys.executable, script, "--policies", str(broken.parent), "--out", str(tmp_path / "x.png")]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert done.returncode != 0 and "empty_run/curve.csv: no rows" in done.stderr


SHIPPED = {  # policy folder: (env id, what its test requires of one episode)
    "lct_ppo": ("OpenDS/LaneChangeTest-v0", {"lane_changes_correct": (18, 18), "mdev_basic_m": (0.0, 0.5), "collisions": (0, 0)}),
    "lct_sac": ("OpenDS/LaneChangeTest-v0", {"lane_changes_correct": (18, 18), "mdev_basic_m": (0.0, 0.6), "collisions": (0, 0)}),
    "platoon_ppo": (
        "OpenDS/ThreeVehiclePlatoon-v0",
        {"stimuli": (10, 10), "stimulus_misses": (0, 0), "collisions": (0, 0), "longitudinal_deviation_mean_m": (0.0, 10.0)},
    ),
    "brake_ppo": (
        "OpenDS/BrakeReaction-v0",
        {"stimuli": (6, 6), "stimulus_misses": (0, 0), "BrakeSign_correct": (3, 3), "collisions": (0, 0)},
    ),
}


# All four are trained on OpenDS's car (issue 17's vehicle model): `opends-gym train <name>`.
@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_policy_passes_its_test(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    """The baselines in agents/policies drive their test through `--agent ppo:PATH` (or
    `sac:PATH`); brake_ppo's drive repeats exactly for its seed."""
    env_id, required = SHIPPED[name]
    model = ROOT / "agents" / "policies" / name / "model.zip"
    algorithm = json.loads((model.parent / "metrics.json").read_text(encoding="utf-8"))["algorithm"]
    runs = []
    for _ in range(2 if name == "brake_ppo" else 1):
        assert cli(["run", env_id, "--agent", f"{algorithm}:{model}", "--json", "--episodes", "1", "--seed", "7"]) == 0
        runs.append(json.loads(capsys.readouterr().out)["episodes"][0])
    episode = runs[0]
    for key, (low, high) in required.items():
        assert low <= episode[key] <= high, (key, episode[key])
    assert all({k: v for k, v in r.items() if k != "wall_s"} == {k: v for k, v in runs[0].items() if k != "wall_s"} for r in runs)


def test_policy_settings_file_chooses_sampled_actions_and_is_checked(quick_run: Path, tmp_path: Path) -> None:
    """`<model>.policy.json` switches a driver to seeded sampled actions; a broken file is
    an error naming it; sampling leaves the global torch RNG alone."""
    import shutil

    import torch

    from opends_gym.drivers.policy import PolicyDriver

    for name in ("model.zip", "model.vecnormalize.pkl"):
        shutil.copy(quick_run / name, tmp_path / name)
    env = gym.make("OpenDS/LaneChangeTest-v0", signs=3, lead_in_m=100, lead_out_m=100, policy_hz=5, max_episode_s=60)
    obs, info = env.reset(seed=0)
    assert PolicyDriver("ppo", tmp_path / "model.zip").deterministic
    (tmp_path / "model.policy.json").write_text('{"deterministic": false}', encoding="utf-8")
    sampling = PolicyDriver("ppo", tmp_path / "model.zip")
    assert not sampling.deterministic

    def actions(seed: int) -> np.ndarray:
        sampling.reset(env, seed)
        return np.array([sampling.act(obs, info) for _ in range(5)])

    torch.manual_seed(123)
    before = torch.rand(1)
    torch.manual_seed(123)
    first = actions(1)
    assert torch.equal(torch.rand(1), before)  # the global stream did not move
    assert np.array_equal(first, actions(1)) and not np.array_equal(first, actions(2))
    assert len({tuple(a) for a in first}) > 1  # samples, not the mean
    (tmp_path / "model.policy.json").write_text('{"deterministic": "no"}', encoding="utf-8")
    with pytest.raises(ValueError, match=r"model\.policy\.json: 'deterministic' must be true or false"):
        PolicyDriver("ppo", tmp_path / "model.zip")
    (tmp_path / "model.policy.json").write_text("{deterministic: false", encoding="utf-8")
    with pytest.raises(ValueError, match=r"model\.policy\.json: line 1: not JSON"):
        PolicyDriver("ppo", tmp_path / "model.zip")


def test_sac_trains_saves_and_drives_through_the_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The off-policy path as configs/lct_sac.yaml runs it (native batch, the rule driver
    cloned into the actor, then SAC): `opends-gym train` writes the model and normaliser, the
    curve shows SAC's gradient steps after the clone's row, and the model drives an episode
    through `--agent sac:PATH` as it does in-process."""
    raw = yaml.safe_load((ROOT / "configs" / "lct_sac.yaml").read_text(encoding="utf-8"))
    raw.update(
        env_kwargs={"signs": 3, "lead_in_m": 100, "lead_out_m": 100, "policy_hz": 5, "max_episode_s": 30},
        total_steps=3072,
        n_envs=16,
        checkpoint_every_steps=1536,
        eval_every_steps=1536,
        eval_episodes=1,
        progress_bar=False,
        stop_at={},
        output=str(tmp_path / "run"),
    )
    raw["warm_start"].update(episodes=1, dagger=1, epochs=5)
    raw["hyperparameters"].update(learning_starts=512, buffer_size=4000, critic_warmup=20, gradient_steps=1)
    (tmp_path / "sac.yaml").write_text(yaml.safe_dump(raw), encoding="utf-8")
    assert cli(["train", str(tmp_path / "sac.yaml")]) == 0
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["algorithm"] == "sac" and metrics["total_steps"] == 3072
    model = tmp_path / "run" / "model.zip"
    assert model.is_file() and (tmp_path / "run" / "model.vecnormalize.pkl").is_file()
    rows = list(csv.DictReader((tmp_path / "run" / "curve.csv").open(encoding="utf-8")))
    assert [int(r["steps"]) for r in rows] == [0, 1536, 3072]
    assert int(rows[0]["warm_start_steps"]) > 100 and rows[0]["gradient_steps"] == ""  # the clone, scored
    # SAC's updates from the batched step (of 16 envs) that completes learning_starts on: one each
    assert [int(r["gradient_steps"]) for r in rows[1:]] == [(1536 - 512) // 16 + 1, (3072 - 512) // 16 + 1]
    from stable_baselines3 import SAC

    assert SAC.load(str(model)).num_timesteps == 3072
    args = ["run", "OpenDS/LaneChangeTest-v0", "--agent", f"sac:{model}", "--json", "--episodes", "1"]
    for option in ("signs=3", "lead_in_m=100", "lead_out_m=100", "policy_hz=5", "max_episode_s=30"):
        args += ["--env-arg", option]
    assert cli(args) == 0
    from opends_gym.drivers.episodes import run_episode
    from opends_gym.drivers.policy import PolicyDriver

    env = gym.make("OpenDS/LaneChangeTest-v0", signs=3, lead_in_m=100, lead_out_m=100, policy_hz=5, max_episode_s=30)
    direct = run_episode(env, PolicyDriver("sac", model), 0)
    env.close()
    episode = json.loads(capsys.readouterr().out)["episodes"][0]
    assert episode["steps"] == direct.steps >= 2 and episode["return"] == pytest.approx(direct.ret)
    raw["hyperparameters"]["critic_warmupp"] = 1
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(raw), encoding="utf-8")
    assert cli(["train", str(tmp_path / "bad.yaml"), "--output", str(tmp_path / "bad")]) == 2
    assert "unknown key(s) critic_warmupp for vec_env native sac; valid keys:" in capsys.readouterr().err


def test_evaluate_script_scores_every_driver_and_shipped_policy() -> None:
    """agents/evaluate.py (the README's baseline tables) lists the rule driver, the heavily
    distracted driver and every shipped policy under the env it was trained on."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, str(ROOT / "agents" / "evaluate.py"), "--episodes", "1", "--markdown"],
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stderr
    sections = {s.split("**")[0]: s for s in done.stdout.split("\n**")[1:]}
    assert set(sections) == {"OpenDS/LaneChangeTest-v0", "OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0"}
    for folder in (ROOT / "agents" / "policies").iterdir():
        if (folder / "metrics.json").is_file():
            meta = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))
            assert f"| {meta['algorithm']} ({folder.name}) |" in sections[meta["env"]]
    for text in sections.values():
        assert "| rule |" in text and "| distracted:heavy |" in text
