"""Train a Ray RLlib PPO policy on an OpenDS env from a `TrainConfig` (`framework: rllib`).

Why: stable-baselines3 trains on one machine; RLlib spreads the env runners (the
simulation, our bottleneck) over every CPU of a Ray cluster, from a laptop to many nodes,
with the same config file. The env is registered through Ray's own registry
(`ray.tune.registry.register_env`), since Ray's workers do not see gymnasium's registry
entries made in the driver; the creator imports `opends_gym` in each worker.

Where it runs: the Ray cluster at `rllib.address` or `RAY_ADDRESS` when set (a head node
started with `ray start --head`, see docs/cluster.md), else a local instance with
`rllib.num_cpus` CPUs (default: all). Outputs in the run folder: `checkpoints/iter_NNNN/`
(RLlib checkpoints, loadable with `Algorithm.from_checkpoint`), `final/` (the last one),
`metrics.json` (per iteration: env steps so far and the mean return of the episodes that
ended in that iteration; NaN when none ended) and `config.json` (the resolved RLlib
settings).

The `rllib:` block of the config (unknown keys are errors, as everywhere):
  address, num_cpus, iterations (default: total_steps / train_batch_size, rounded up),
  num_env_runners, num_envs_per_env_runner, num_cpus_per_env_runner,
  rollout_fragment_length, train_batch_size, minibatch_size, num_epochs, lr, gamma,
  lambda_, clip_param, entropy_coeff, vf_loss_coeff, fcnet_hiddens,
  checkpoint_every_iterations, object_store_memory_mb.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import gymnasium as gym

from ..extras import require
from ..jsonsafe import json_safe
from .config import TrainConfig

ENV_PREFIX = "opends_gym/"


class RllibConfigError(ValueError):
    """The `rllib:` block of a training config is invalid (unknown key, bad value)."""


@dataclass(frozen=True)
class RllibSettings:
    """The `rllib:` block of a training config, typed (typos are errors)."""

    address: str | None = None
    num_cpus: int | None = None
    iterations: int | None = None
    num_env_runners: int = 2
    num_envs_per_env_runner: int = 1
    num_cpus_per_env_runner: int = 1
    rollout_fragment_length: int | str = "auto"
    train_batch_size: int = 4000
    minibatch_size: int = 128
    num_epochs: int = 10
    lr: float = 3e-4
    gamma: float = 0.99
    lambda_: float = 0.95
    clip_param: float = 0.2
    entropy_coeff: float = 0.0
    vf_loss_coeff: float = 1.0
    fcnet_hiddens: list[int] = field(default_factory=lambda: [64, 64])
    checkpoint_every_iterations: int = 10
    object_store_memory_mb: int | None = None

    @staticmethod
    def from_block(block: dict[str, Any]) -> RllibSettings:
        names = {f.name for f in fields(RllibSettings)}
        unknown = sorted(set(block) - names)
        if unknown:
            raise RllibConfigError(f"rllib: unknown key(s) {', '.join(unknown)}; valid keys: {', '.join(sorted(names))}")
        try:
            s = RllibSettings(**block)
        except TypeError as e:
            raise RllibConfigError(f"rllib: {e}") from None
        for key in ("num_envs_per_env_runner", "train_batch_size", "minibatch_size", "num_epochs", "checkpoint_every_iterations"):
            if int(getattr(s, key)) <= 0:
                raise RllibConfigError(f"rllib: {key} must be positive, not {getattr(s, key)!r}")
        if s.num_env_runners < 0:
            raise RllibConfigError(f"rllib: num_env_runners must be 0 or more, not {s.num_env_runners!r}")
        if s.iterations is not None and s.iterations <= 0:
            raise RllibConfigError(f"rllib: iterations must be positive, not {s.iterations!r}")
        if s.minibatch_size > s.train_batch_size:
            raise RllibConfigError(f"rllib: minibatch_size ({s.minibatch_size}) exceeds train_batch_size ({s.train_batch_size})")
        return s

    def iterations_for(self, total_steps: int) -> int:
        return self.iterations if self.iterations is not None else max(1, math.ceil(total_steps / self.train_batch_size))


def env_name(env_id: str) -> str:
    """The name an OpenDS id is registered under in Ray's registry."""
    return ENV_PREFIX + env_id.split(":", 1)[-1]


def make_env(env_id: str, env_config: dict[str, Any]) -> gym.Env[Any, Any]:
    """Build the env in an RLlib worker (the `opends_gym:` prefix imports and registers our ids)."""
    plain = env_id.split(":", 1)[-1]
    return gym.make(f"opends_gym:{plain}", **dict(env_config))


def register(env_id: str) -> str:
    """Register `env_id` with Ray's env registry; returns the registered name."""
    from ray.tune.registry import register_env

    name = env_name(env_id)
    register_env(name, lambda env_config: make_env(env_id, env_config))
    return name


def build_config(cfg: TrainConfig, s: RllibSettings) -> Any:
    """The PPOConfig (RLlib's new API stack: RLModule, Learner, EnvRunner) for `cfg`."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    return (
        PPOConfig()
        .environment(env=register(cfg.env), env_config=dict(cfg.env_kwargs))
        .framework("torch")
        .env_runners(
            num_env_runners=s.num_env_runners,
            num_envs_per_env_runner=s.num_envs_per_env_runner,
            num_cpus_per_env_runner=s.num_cpus_per_env_runner,
            rollout_fragment_length=s.rollout_fragment_length,
        )
        .learners(num_learners=0)
        .training(
            train_batch_size_per_learner=s.train_batch_size,
            minibatch_size=s.minibatch_size,
            num_epochs=s.num_epochs,
            lr=s.lr,
            gamma=s.gamma,
            lambda_=s.lambda_,
            clip_param=s.clip_param,
            entropy_coeff=s.entropy_coeff,
            vf_loss_coeff=s.vf_loss_coeff,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=list(s.fcnet_hiddens)))
        .debugging(seed=cfg.seed)
    )


def _connect(s: RllibSettings) -> bool:
    """Join the configured cluster or start a local instance; True if we started Ray here."""
    import ray

    if ray.is_initialized():
        return False
    address = s.address or os.environ.get("RAY_ADDRESS") or None
    if address:
        ray.init(address=address, log_to_driver=False)
        return True
    store = int(s.object_store_memory_mb * 1024 * 1024) if s.object_store_memory_mb else None
    ray.init(num_cpus=s.num_cpus or os.cpu_count() or 1, object_store_memory=store, include_dashboard=False, log_to_driver=False)
    return True


def _episode_return(result: dict[str, Any]) -> float:
    value = result.get("env_runners", {}).get("episode_return_mean", math.nan)
    return float(value) if value is not None else math.nan


def train(cfg: TrainConfig, base_dir: Path, out_dir: Path | None = None) -> dict[str, Any]:
    """Train per `cfg` with RLlib; returns a summary (also in `metrics.json`)."""
    s = RllibSettings.from_block(dict(cfg.rllib))
    if cfg.algorithm != "ppo":
        raise RllibConfigError(f"framework rllib supports algorithm 'ppo' here, not {cfg.algorithm!r}")
    require("cluster", "ray", "training with framework: rllib")
    out = out_dir or cfg.output_dir(base_dir)
    out.mkdir(parents=True, exist_ok=True)
    iterations = s.iterations_for(cfg.total_steps)
    started = _connect(s)
    import ray

    algo: Any = None
    try:
        algo = build_config(cfg, s).build_algo()
        history: list[dict[str, float]] = []
        checkpoints: list[str] = []
        for i in range(1, iterations + 1):
            result = algo.train()
            history.append(
                {
                    "iteration": float(i),
                    "env_steps": float(result.get("num_env_steps_sampled_lifetime", math.nan)),
                    "episode_return_mean": _episode_return(result),
                }
            )
            if i % s.checkpoint_every_iterations == 0 or i == iterations:
                checkpoints.append(str(algo.save_to_path(str(out / "checkpoints" / f"iter_{i:04d}"))))
        final = str(algo.save_to_path(str(out / "final")))
        returns = [h["episode_return_mean"] for h in history]
        finite = [r for r in returns if math.isfinite(r)]
        summary: dict[str, Any] = {
            "framework": "rllib",
            "env": cfg.env,
            "iterations": iterations,
            "env_steps": history[-1]["env_steps"],
            "episode_return_mean": finite[-1] if finite else math.nan,
            "history": history,
            "checkpoints": checkpoints,
            "final_checkpoint": final,
            "cluster_resources": {k: float(v) for k, v in ray.cluster_resources().items() if k in ("CPU", "GPU", "memory")},
        }
        (out / "metrics.json").write_text(json.dumps(json_safe(summary), indent=2) + "\n", encoding="utf-8")
        (out / "config.json").write_text(json.dumps({"env": cfg.env, "env_kwargs": cfg.env_kwargs, **vars(s)}, indent=2) + "\n")
        return json_safe(summary)
    finally:
        if algo is not None:
            algo.stop()
        if started:
            ray.shutdown()
