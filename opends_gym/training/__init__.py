"""Training entry points: configs from YAML, stable-baselines3 (and Ray RLlib) runners."""

from .config import TrainConfig, load_train_config

__all__ = ["TrainConfig", "load_train_config"]
