"""Train a stable-baselines3 policy on an OpenDS env from a `TrainConfig`.

Why: one call gives everything a baseline needs to be reused and trusted: periodic
checkpoints, periodic evaluation, a training curve (CSV), the final model with its
observation normaliser (what `--agent ppo:PATH` loads), and the env's own metrics of the
final policy.

Outputs in the run folder: `model.zip`, `model.vecnormalize.pkl`, `checkpoints/`,
`monitor/` (per-episode returns; `checkpoints/` hold each checkpoint's normaliser too, so a
run can be stopped at a good checkpoint and `--agent ppo:PATH` drives it), `curve.csv` (steps, mean return of the last 10
episodes), `evaluations.npz` (SB3's EvalCallback), `metrics.json` (final evaluation).
"""

from __future__ import annotations

import csv
import json
import math
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..extras import require
from ..jsonsafe import json_safe
from .config import TrainConfig


def make_env(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """A picklable env factory: the `opends_gym:` prefix registers the ids in subprocesses."""
    return gym.make(env_id if ":" in env_id else f"opends_gym:{env_id}", **env_kwargs)


def _algorithm(name: str) -> Any:
    sb3 = require("rl", "stable_baselines3", "opends-gym train")

    return getattr(sb3, name.upper())


def build_vec_env(cfg: TrainConfig, n_envs: int, seed: int, monitor_dir: Path | None) -> Any:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    cls = SubprocVecEnv if cfg.vec_env == "subproc" and n_envs > 1 else DummyVecEnv
    return make_vec_env(
        partial(make_env, cfg.env, dict(cfg.env_kwargs)),
        n_envs=n_envs,
        seed=seed,
        vec_env_cls=cls,
        monitor_dir=str(monitor_dir) if monitor_dir else None,
    )


def train(cfg: TrainConfig, base_dir: Path, out_dir: Path | None = None, resume: Path | None = None) -> dict[str, Any]:
    """Train per `cfg`; returns the final evaluation metrics (also in `metrics.json`).

    `resume`: a finished run folder (its `model.zip` and normaliser) to continue training
    for another `total_steps`; the curve's step counts continue from where it stopped."""
    require("rl", "stable_baselines3", "opends-gym train")
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    out = out_dir or cfg.output_dir(base_dir)
    out.mkdir(parents=True, exist_ok=True)
    venv = build_vec_env(cfg, cfg.n_envs, cfg.seed, out / "monitor")
    eval_env = build_vec_env(cfg, 1, cfg.seed + 10_000, None)
    if cfg.normalize_observations or cfg.normalize_rewards:
        venv = VecNormalize(venv, norm_obs=cfg.normalize_observations, norm_reward=cfg.normalize_rewards)
        eval_env = VecNormalize(eval_env, norm_obs=cfg.normalize_observations, norm_reward=False, training=False)
    algo = _algorithm(cfg.algorithm)
    if resume is not None:
        if not (resume / "model.zip").is_file():
            raise ValueError(f"nothing to resume: no model.zip in {resume}")
        stats = resume / "model.vecnormalize.pkl"
        if isinstance(venv, VecNormalize) and stats.is_file():
            venv = VecNormalize.load(str(stats), venv.venv)
            eval_env.obs_rms = venv.obs_rms
        model = algo.load(str(resume / "model.zip"), env=venv, device="cpu")
    else:
        model = algo(cfg.policy, venv, seed=cfg.seed, policy_kwargs=dict(cfg.policy_kwargs), device="cpu", verbose=0, **cfg.hyperparameters)
    start_steps = int(model.num_timesteps)
    per_env = max(1, cfg.n_envs)
    callbacks = CallbackList(
        [
            CheckpointCallback(
                max(1, cfg.checkpoint_every_steps // per_env), str(out / "checkpoints"), name_prefix="model", save_vecnormalize=True
            ),
            EvalCallback(
                eval_env,
                n_eval_episodes=cfg.eval_episodes,
                eval_freq=max(1, cfg.eval_every_steps // per_env),
                log_path=str(out),
                best_model_save_path=str(out / "best"),
                deterministic=True,
                verbose=0,
            ),
        ]
    )
    model.learn(total_timesteps=cfg.total_steps, callback=callbacks, progress_bar=cfg.progress_bar, reset_num_timesteps=resume is None)
    model.save(str(out / "model.zip"))
    if isinstance(venv, VecNormalize):
        venv.save(str(out / "model.vecnormalize.pkl"))
    venv.close()
    eval_env.close()
    write_curve(out / "monitor", out / "curve.csv", start_steps=start_steps)
    metrics = evaluate_policy_file(cfg, out / "model.zip", episodes=cfg.eval_episodes)
    (out / "metrics.json").write_text(json.dumps(json_safe(metrics), indent=2), encoding="utf-8")
    return metrics


def write_curve(monitor_dir: Path, out_csv: Path, window: int = 10, start_steps: int = 0) -> list[tuple[int, float]]:
    """Training curve from the Monitor files: (env steps so far, mean return of the last
    `window` episodes); `start_steps` offsets a resumed run."""
    rows: list[tuple[float, float, int]] = []  # (wall time, return, length)
    for f in sorted(monitor_dir.glob("*.monitor.csv")):
        with f.open(encoding="utf-8") as fh:
            header = fh.readline().lstrip("#")  # the JSON header line, with the env's start time
            try:
                start = float(json.loads(header).get("t_start", 0.0))
            except (ValueError, AttributeError):
                start = 0.0
            for row in csv.DictReader(fh):
                # by the episode's end on the clock: each Monitor's `t` counts from its own
                # env's creation, and the envs are created one after the other
                rows.append((start + float(row["t"]), float(row["r"]), int(row["l"])))
    rows.sort()
    curve: list[tuple[int, float]] = []
    steps = start_steps
    returns: list[float] = []
    for _, r, n in rows:
        steps += n
        returns.append(r)
        curve.append((steps, float(np.mean(returns[-window:]))))
    with out_csv.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["steps", f"mean_return_last_{window}"])
        w.writerows(curve)
    return curve


def evaluate_policy_file(cfg: TrainConfig, model_path: Path, episodes: int = 3, seed: int = 1000) -> dict[str, Any]:
    """Run the saved policy through the same driver interface as `opends-gym run`."""
    from ..drivers.episodes import run_episode
    from ..drivers.policy import PolicyDriver

    driver = PolicyDriver(cfg.algorithm, model_path)
    env = make_env(cfg.env, dict(cfg.env_kwargs))
    per_episode = []
    try:
        for i in range(episodes):
            ep = run_episode(env, driver, seed + i)
            per_episode.append({"return": ep.ret, **ep.metrics})
    finally:
        env.close()
    keys = [k for k, v in per_episode[0].items() if isinstance(v, (int, float))]
    summary = {}
    for k in keys:
        values = [float(e[k]) for e in per_episode]
        summary[k] = float(np.nanmean(values)) if any(math.isfinite(v) for v in values) else math.nan
    return {"env": cfg.env, "algorithm": cfg.algorithm, "total_steps": cfg.total_steps, "episodes": per_episode, "mean": summary}
