"""A driver that runs a saved stable-baselines3 policy.

Why: trained baselines are compared with the rule and distracted drivers under the same
metrics, through the same `--agent` interface (`ppo:PATH`, `sac:PATH`, or a bundled policy by name:
`ppo:lct` is `opends_gym.resources`' `lct_ppo`). Observation
normalisation statistics saved beside the model (`<model>.vecnormalize.pkl`, written by
`opends-gym train`) are applied the same way as during training.

Actions are the policy's mean (`deterministic=True`) unless a `<model>.policy.json` beside
the model says `{"deterministic": false}`: some PPO policies only work with the sampled
actions they were trained with (the shipped brake policy's mean action does not wait behind
a lead car standing after an emergency brake; its samples do). Sampled actions come from
the driver's own torch generator state, seeded in `reset(env, seed)`, so the same seed gives
the same drive and the global torch RNG is left alone.
"""

from __future__ import annotations

import json
import pickle
import re
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..extras import require
from ..resources import resolve_policy

ALGORITHMS = ("ppo", "sac", "a2c", "td3")


def _beside(model_path: Path, suffix: str) -> Path:
    """`<model>` + suffix, next to `<model>.zip`."""
    return model_path.with_name(model_path.name.removesuffix(".zip") + suffix)


def normalizer_path(model_path: Path) -> Path:
    """Where `opends-gym train` saves the observation normaliser of a model: beside it, or
    for a checkpoint `<prefix>_<N>_steps.zip` where SB3's `CheckpointCallback` puts it
    (`<prefix>_vecnormalize_<N>_steps.pkl`), so a checkpoint drives like a finished run."""
    beside = _beside(model_path, ".vecnormalize.pkl")
    match = re.fullmatch(r"(.+)_(\d+)_steps(\.zip)?", model_path.name)
    if beside.exists() or match is None:
        return beside
    return model_path.with_name(f"{match[1]}_vecnormalize_{match[2]}_steps.pkl")


def settings_path(model_path: Path) -> Path:
    """The optional `<model>.policy.json` with how to act (`deterministic`)."""
    return _beside(model_path, ".policy.json")


def _read_deterministic(model_path: Path) -> bool:
    path = settings_path(model_path)
    if not path.exists():
        return True
    try:
        settings = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: line {e.lineno}: not JSON ({e.msg})") from e
    value = settings.get("deterministic", True) if isinstance(settings, dict) else None
    if not isinstance(value, bool):
        raise ValueError(f"{path}: 'deterministic' must be true or false, not {value!r}")
    return value


class PolicyDriver:
    """Acts with `model.predict(obs, deterministic=...)` of a saved SB3 model (the mean
    action unless the model's `.policy.json` or `deterministic=False` asks for samples)."""

    def __init__(self, algorithm: str, path: str | Path, deterministic: bool | None = None) -> None:
        algorithm = algorithm.lower()
        if algorithm not in ALGORITHMS:
            raise ValueError(f"unknown algorithm {algorithm!r}; choose from {', '.join(ALGORITHMS)}")
        self.name = f"{algorithm}:{path}"
        self.path = resolve_policy(algorithm, path)
        sb3 = require("rl", "stable_baselines3", f"the {algorithm.upper()} agent")

        cls = getattr(sb3, algorithm.upper())
        self.model = cls.load(str(self.path), device="cpu")
        self.obs_rms: Any = None
        self.clip_obs = 10.0
        self.epsilon = 1e-8
        stats = normalizer_path(self.path)
        if stats.exists():
            with stats.open("rb") as f:
                vec_normalize = pickle.load(f)  # a file our own trainer wrote
            self.obs_rms = vec_normalize.obs_rms
            self.clip_obs = float(vec_normalize.clip_obs)
            self.epsilon = float(vec_normalize.epsilon)
        self.deterministic = _read_deterministic(self.path) if deterministic is None else deterministic
        self._rng_state: Any = None

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        if env.observation_space.shape != self.model.observation_space.shape:
            raise ValueError(
                f"policy {self.path} expects observations of shape {self.model.observation_space.shape}, "
                f"the env gives {env.observation_space.shape}"
            )
        if not self.deterministic:
            torch = require("rl", "torch", f"the {self.name} agent")
            self._rng_state = torch.Generator().manual_seed(int(seed)).get_state()

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        x = np.asarray(obs, dtype=np.float32)
        if self.obs_rms is not None:
            x = (x - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon)
            x = np.clip(x, -self.clip_obs, self.clip_obs).astype(np.float32)
        if self.deterministic:
            action, _ = self.model.predict(x, deterministic=True)
            return action
        import torch

        if self._rng_state is None:
            raise RuntimeError("a sampling policy driver needs reset(env, seed) before act()")
        with torch.random.fork_rng(devices=[]):  # sample from this driver's stream only
            torch.set_rng_state(self._rng_state)
            action, _ = self.model.predict(x, deterministic=False)
            self._rng_state = torch.get_rng_state()
        return action
