"""Ray RLlib training (`framework: rllib`): `opends-gym train configs/rllib_ppo.yaml` on a local Ray instance."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from opends_gym.training import load_train_config
from opends_gym.training.rllib import RllibSettings, env_name

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "rllib_ppo.yaml"
CLI = "from opends_gym.cli.main import main; raise SystemExit(main())"


def _train(*args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}  # always a local instance here
    env["RAY_USAGE_STATS_ENABLED"] = "0"
    return subprocess.run([sys.executable, "-c", CLI, "train", *args], capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)


def test_train_two_iterations_on_local_ray(tmp_path: Path) -> None:
    cfg, _ = load_train_config(CONFIG)
    batch = RllibSettings.from_block(dict(cfg.rllib)).train_batch_size
    out = tmp_path / "run"
    proc = _train(str(CONFIG), "--total-steps", str(2 * batch), "--output", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads(proc.stdout)
    assert summary["iterations"] == 2
    assert summary["env_steps"] >= 2 * batch
    metrics = json.loads((out / "metrics.json").read_text())
    assert [h["iteration"] for h in metrics["history"]] == [1.0, 2.0]
    returns = [h["episode_return_mean"] for h in metrics["history"]]
    # 30 s episodes (300 steps) and 2000-step batches: every iteration ends episodes
    assert all(r is not None and math.isfinite(r) for r in returns), returns
    final = Path(metrics["final_checkpoint"])
    assert final.is_dir() and any(final.iterdir())
    assert (out / "checkpoints" / "iter_0002").is_dir()
    assert metrics["cluster_resources"]["CPU"] >= 1
    _check_restored_policy(final / "learner_group" / "learner" / "rl_module" / "default_policy")


def _check_restored_policy(module_dir: Path) -> None:
    """The saved checkpoint is a real RLlib policy: it loads (without Ray) and acts on the env."""
    import gymnasium as gym
    import numpy as np
    import torch
    from ray.rllib.core.rl_module import RLModule

    cfg, _ = load_train_config(CONFIG)
    module = RLModule.from_checkpoint(module_dir)
    env = gym.make(cfg.env, **cfg.env_kwargs)
    obs, _ = env.reset(seed=0)
    out = module.forward_inference({"obs": torch.as_tensor(obs[None], dtype=torch.float32)})
    logits = out["action_dist_inputs"].detach().numpy()
    assert logits.shape == (1, 2 * env.action_space.shape[0]) and np.all(np.isfinite(logits))


def test_bad_rllib_key_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(CONFIG.read_text().replace("num_env_runners: 2", "num_env_runner: 2"))
    proc = _train(str(bad), "--output", str(tmp_path / "out"))
    assert proc.returncode != 0
    assert "rllib: unknown key(s) num_env_runner" in proc.stderr
    assert "num_env_runners" in proc.stderr  # the valid keys are listed
    assert not (tmp_path / "out" / "metrics.json").exists()


def test_settings_validation_and_names() -> None:
    with pytest.raises(ValueError, match="minibatch_size"):
        RllibSettings.from_block({"train_batch_size": 100, "minibatch_size": 200})
    with pytest.raises(ValueError, match="iterations must be positive"):
        RllibSettings.from_block({"iterations": 0})
    assert RllibSettings.from_block({"train_batch_size": 1000}).iterations_for(2500) == 3
    assert env_name("opends_gym:OpenDS/LaneChangeTest-v0") == "opends_gym/OpenDS/LaneChangeTest-v0"
