"""Training configs: YAML files in `configs/` loaded into a frozen dataclass.

Why: a training run must be repeatable from one file, and a typo in a key must stop the
run instead of silently training with a default (docs/architecture.md#configs).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..hints import meant

ALGORITHMS = ("ppo", "sac", "a2c", "td3")
FRAMEWORKS = ("sb3", "rllib")
VEC_ENVS = ("dummy", "subproc", "native")


@dataclass(frozen=True)
class TrainConfig:
    """One training run. Times in policy steps (`*_steps`), paths relative to the config."""

    env: str
    algorithm: str = "ppo"
    framework: str = "sb3"
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    total_steps: int = 100_000
    n_envs: int = 4
    vec_env: str = "dummy"  # dummy | subproc (SB3 over single envs) | native (our PPO on the native batch)
    seed: int = 0
    normalize_observations: bool = True
    normalize_rewards: bool = True
    policy: str = "MlpPolicy"
    policy_kwargs: dict[str, Any] = field(default_factory=dict)
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    checkpoint_every_steps: int = 50_000
    eval_every_steps: int = 20_000
    eval_episodes: int = 2
    output: str = "runs/{name}"
    progress_bar: bool = True
    stop_at: dict[str, list[float]] = field(
        default_factory=dict
    )  # vec_env native: metric -> [low, high] of an evaluation that ends the run
    warm_start: dict[str, Any] = field(default_factory=dict)  # vec_env native: clone a driver first (training.warm_start)
    rllib: dict[str, Any] = field(default_factory=dict)  # framework rllib: num_env_runners, iterations, train_batch_size, ...
    name: str = ""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ValueError(f"algorithm must be one of {', '.join(ALGORITHMS)}, not {self.algorithm!r}")
        if self.framework not in FRAMEWORKS:
            raise ValueError(f"framework must be one of {', '.join(FRAMEWORKS)}, not {self.framework!r}")
        if self.vec_env not in VEC_ENVS:
            raise ValueError(f"vec_env must be one of {', '.join(VEC_ENVS)}, not {self.vec_env!r}")
        for key in ("env_kwargs", "policy_kwargs", "hyperparameters", "stop_at", "warm_start", "rllib"):
            if not isinstance(getattr(self, key), dict):
                raise ValueError(f"{key} must be a mapping of keys to values, not {getattr(self, key)!r}")
        for metric, bounds in self.stop_at.items():
            if not (isinstance(bounds, list | tuple) and len(bounds) == 2 and all(isinstance(b, int | float) for b in bounds)):
                raise ValueError(f"stop_at: {metric} needs [low, high], not {bounds!r}")
        if self.warm_start and self.framework == "sb3" and self.vec_env != "native":
            raise ValueError(f"warm_start needs vec_env native (the native PPO trainer), not vec_env {self.vec_env!r}")
        for key in ("total_steps", "n_envs", "checkpoint_every_steps", "eval_every_steps"):
            if int(getattr(self, key)) <= 0:
                raise ValueError(f"{key} must be positive")

    def output_dir(self, base: Path) -> Path:
        return (base / self.output.format(name=self.name)).resolve()


def load_train_config(path: str | Path, overrides: dict[str, Any] | None = None) -> tuple[TrainConfig, Path]:
    """(config, folder it was read from); unknown keys raise ValueError naming the file."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except yaml.YAMLError as e:
        raise ValueError(f"{path}: not valid YAML: {e}") from None
    if not isinstance(raw, dict):
        raise ValueError(f"{path}: a training config is a mapping of keys to values")
    raw = {**raw, **(overrides or {})}
    raw.setdefault("name", path.stem)
    names = {f.name for f in dataclasses.fields(TrainConfig)}
    unknown = sorted(set(raw) - names)
    if unknown:
        hints = "".join(meant(k, names) for k in unknown)
        raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)}{hints}; valid keys: {', '.join(sorted(names))}")
    if "env" not in raw:
        raise ValueError(f"{path}: missing required key 'env'")
    try:
        return TrainConfig(**raw), path.parent
    except (TypeError, ValueError) as e:
        raise ValueError(f"{path}: {e}") from None
