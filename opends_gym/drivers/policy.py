"""A driver that runs a saved stable-baselines3 policy.

Why: trained baselines are compared with the rule and distracted drivers under the same
metrics, through the same `--agent` interface (`ppo:PATH`, `sac:PATH`). Observation
normalisation statistics saved beside the model (`<model>.vecnormalize.pkl`, written by
`opends-gym train`) are applied the same way as during training.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

ALGORITHMS = ("ppo", "sac", "a2c", "td3")


def normalizer_path(model_path: Path) -> Path:
    """Where `opends-gym train` saves the observation normaliser of a model."""
    return model_path.with_name(model_path.name.removesuffix(".zip") + ".vecnormalize.pkl")


class PolicyDriver:
    """Acts with `model.predict(obs, deterministic=True)` of a saved SB3 model."""

    def __init__(self, algorithm: str, path: str | Path) -> None:
        algorithm = algorithm.lower()
        if algorithm not in ALGORITHMS:
            raise ValueError(f"unknown algorithm {algorithm!r}; choose from {', '.join(ALGORITHMS)}")
        self.name = f"{algorithm}:{path}"
        self.path = Path(path)
        if not self.path.exists() and not self.path.with_suffix(".zip").exists():
            raise FileNotFoundError(f"no saved policy at {self.path}")
        import stable_baselines3 as sb3

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

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        if env.observation_space.shape != self.model.observation_space.shape:
            raise ValueError(
                f"policy {self.path} expects observations of shape {self.model.observation_space.shape}, "
                f"the env gives {env.observation_space.shape}"
            )

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        x = np.asarray(obs, dtype=np.float32)
        if self.obs_rms is not None:
            x = (x - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon)
            x = np.clip(x, -self.clip_obs, self.clip_obs).astype(np.float32)
        action, _ = self.model.predict(x, deterministic=True)
        return action
