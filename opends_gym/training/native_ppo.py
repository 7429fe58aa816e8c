"""PPO on the native batch (`vec_env: native`): minutes to a trained driver on two cores.

Why: SB3's PPO steps its envs one Python call per env and trains minibatches of 256; on
two cores the documented 1M-step LCT run took ~9 min (~40k gradient steps). Here the envs
are one `NativeVectorEnv` (a hundred or more envs as numpy arrays, one call per batched
step), the policy acts on the whole batch with one torch call, and the updates use
minibatches of thousands, so a run to the LCT's bar takes a few thousand gradient steps.

The policy is SB3's own `ActorCriticPolicy` inside a `stable_baselines3.PPO` object and the
normaliser an SB3 `VecNormalize`: the run folder holds `model.zip` and
`model.vecnormalize.pkl` as `opends-gym train` always wrote them, so `--agent ppo:PATH`,
`PPO.load` and `--resume` read them unchanged (the bundled policy format).

The batch autoresets on the NEXT step (Gymnasium's default): the step after an episode ends
only resets that env (reward 0, the action ignored), so it is no transition and is masked
out of the loss; the observation returned when an episode ends is its last one, whose value
bootstraps a truncated episode (a terminated one gets none).

Deterministic for a seed on one machine: the envs are seeded `seed + i`, torch's generator
with `seed`, torch runs `torch_threads` threads (default 1) and minibatches come from a
numpy generator seeded with `seed` (tested: two runs give the same curve).

Outputs in the run folder: `model.zip`, `model.vecnormalize.pkl`, `checkpoints/`
(`model_<N>_steps.zip` with `model_vecnormalize_<N>_steps.pkl`, as SB3's callback names
them), `curve.csv` (per rollout: env steps, wall seconds with and without the evaluations, the
mean return of the last 10 episodes, and the evaluation's metrics where one ran),
`evaluations.npz` (as SB3's EvalCallback writes it), `metrics.json` (the final evaluation).

`warm_start:` in the config clones a driver into the policy before PPO (behaviour cloning
with DAgger, `training.warm_start`; the curve's row at step 0 scores the clone), and
`value_warmup` rollouts then train only the value function: from a random policy PPO
settled on stopping the car in the brake and platoon tests.

`stop_at` in the config (metric: [low, high], e.g. lane_changes_correct: [18, 18]) ends
the run at the first evaluation whose mean metrics are all within bounds; that checkpoint
is the run's `model.zip`.
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..extras import require
from ..jsonsafe import json_safe
from .config import TrainConfig
from .warm_start import WarmStart, clone, demonstrations

Progress = Callable[[int, str], None]  # (env steps done of total_steps, a note: the last returns)


@dataclass(frozen=True)
class NativePpoSettings:
    """The `hyperparameters:` of a native PPO run (SB3's names where SB3 has them)."""

    n_steps: int = 64  # steps per env per rollout
    batch_size: int = 4096  # minibatch, in transitions
    n_epochs: int = 4
    learning_rate: float = 1e-3
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = None  # stop an update's epochs once the KL estimate passes it
    anneal_lr: bool = True  # linearly to 0 over total_steps
    desync: bool = True  # spread the envs over the episode before training (see `desync`)
    value_warmup: int = 0  # first rollouts that train only the value function (after a warm start)
    torch_threads: int = 1

    @staticmethod
    def from_block(path_hint: str, block: dict[str, Any]) -> NativePpoSettings:
        names = {f.name for f in fields(NativePpoSettings)}
        unknown = sorted(set(block) - names)
        if unknown:
            valid = ", ".join(sorted(names))
            raise ValueError(f"{path_hint}hyperparameters: unknown key(s) {', '.join(unknown)} for vec_env native; valid keys: {valid}")
        s = NativePpoSettings(**block)
        for key in ("n_steps", "batch_size", "n_epochs", "torch_threads"):
            if int(getattr(s, key)) <= 0:
                raise ValueError(f"{path_hint}hyperparameters: {key} must be positive, not {getattr(s, key)!r}")
        if int(s.value_warmup) < 0:
            raise ValueError(f"{path_hint}hyperparameters: value_warmup must be >= 0, not {s.value_warmup!r}")
        return s


class _Spaces:
    """Just the spaces and size of a vector env: what SB3's PPO and VecNormalize read when
    they are built (neither steps it)."""

    def __init__(self, env: gym.vector.VectorEnv) -> None:
        from stable_baselines3.common.vec_env import VecEnv

        class Stub(VecEnv):  # type: ignore[misc]
            def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
                return [None] * self.num_envs  # (render_mode: none)

            def reset(self, *args: Any, **kwargs: Any) -> Any:
                raise NotImplementedError("the native trainer steps the batch itself")

            step_async = step_wait = close = set_attr = env_method = env_is_wrapped = reset

        self.venv = Stub(1, env.single_observation_space, env.single_action_space)


def _normalizer(stub: Any, gamma: float, norm_obs: bool, norm_reward: bool) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    return VecNormalize(stub, norm_obs=norm_obs, norm_reward=norm_reward, gamma=gamma)


class _RewardScaler:
    """VecNormalize's reward scaling (rewards divided by the std of the discounted return),
    skipping the autoreset steps that are no transitions."""

    def __init__(self, rms: Any, n: int, gamma: float, clip: float, epsilon: float) -> None:
        self.rms, self.gamma, self.clip, self.epsilon = rms, gamma, clip, epsilon
        self.returns = np.zeros(n)

    def __call__(self, reward: np.ndarray, valid: np.ndarray, ended: np.ndarray) -> np.ndarray:
        self.returns = np.where(valid, self.returns * self.gamma + reward, self.returns)
        self.rms.update(self.returns[valid])
        self.returns[ended & valid] = 0.0
        return np.clip(reward / np.sqrt(self.rms.var + self.epsilon), -self.clip, self.clip)


def train(
    cfg: TrainConfig,
    base_dir: Path,
    out_dir: Path | None = None,
    resume: Path | None = None,
    progress: Progress | None = None,
    evaluate: Callable[[TrainConfig, Path], dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Train per `cfg` with PPO on the native batch; returns the final evaluation (also in
    `metrics.json`). `evaluate(cfg, model.zip)` scores a checkpoint (default: the single
    env through `--agent`'s driver, as `opends-gym run` does)."""
    for module in ("stable_baselines3", "torch"):
        require("rl", module, "opends-gym train")
    import torch
    from stable_baselines3 import PPO

    from .sb3 import evaluate_policy_file

    if cfg.algorithm != "ppo":
        raise ValueError(f"vec_env native trains algorithm 'ppo', not {cfg.algorithm!r}")
    s = NativePpoSettings.from_block("", dict(cfg.hyperparameters))
    warm = WarmStart.from_block("", dict(cfg.warm_start)) if cfg.warm_start and resume is None else None
    score = evaluate or (lambda c, model: evaluate_policy_file(c, model, episodes=c.eval_episodes))
    out = out_dir or cfg.output_dir(base_dir)
    (out / "checkpoints").mkdir(parents=True, exist_ok=True)
    env_id = cfg.env.split(":", 1)[-1]
    envs = gym.make_vec(env_id, num_envs=cfg.n_envs, vectorization_mode="vector_entry_point", record_metrics=False, **cfg.env_kwargs)
    threads = torch.get_num_threads()
    torch.set_num_threads(s.torch_threads)
    torch.manual_seed(cfg.seed)
    try:
        stub = _Spaces(envs).venv
        if resume is not None:
            if not (resume / "model.zip").is_file():
                raise ValueError(f"nothing to resume: no model.zip in {resume}")
            model = PPO.load(str(resume / "model.zip"), device="cpu")
            stats = resume / "model.vecnormalize.pkl"
            from stable_baselines3.common.vec_env import VecNormalize

            fresh = _normalizer(stub, s.gamma, cfg.normalize_observations, cfg.normalize_rewards)
            norm = VecNormalize.load(str(stats), stub) if stats.is_file() else fresh
        else:
            model = PPO(cfg.policy, stub, n_steps=2, batch_size=2, seed=cfg.seed, policy_kwargs=dict(cfg.policy_kwargs), device="cpu")
            norm = _normalizer(stub, s.gamma, cfg.normalize_observations, cfg.normalize_rewards)
        run = _Run(cfg, s, envs, model, norm, out, progress, score, time.perf_counter())
        run.frozen_obs = bool(cfg.warm_start)  # (a resumed warm-started run keeps the clone's scale too)
        if warm is not None:
            run.warm_start(warm)
        return run.learn()
    finally:
        envs.close()
        torch.set_num_threads(threads)


def gae(rew: np.ndarray, val: np.ndarray, term: np.ndarray, end: np.ndarray, gamma: float, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Generalised advantage estimates and returns of a (steps, envs) rollout; `val` has one
    more row (the values of the observations after the last step). A chain stops where an
    episode ends (`end`), and only a terminated episode's last step has no bootstrap value:
    a truncated one is worth the value of its last observation."""
    adv = np.zeros_like(rew)
    last = np.zeros(rew.shape[1], dtype=rew.dtype)
    for t in reversed(range(rew.shape[0])):
        delta = rew[t] + gamma * val[t + 1] * (~term[t]) - val[t]
        last = delta + gamma * lam * (~end[t]) * last
        adv[t] = last
    return adv, adv + val[:-1]


def desync(envs: Any, rng: np.random.Generator, limit: int = 100_000) -> np.ndarray:
    """Spread the envs over the course of an episode; returns the observations after it.

    Why: all envs start together on the same track, so without this every rollout of a few
    dozen steps holds the same stretch of road in all envs, and each update forgets the rest.
    The envs act neutrally (zero actions) until the first episode ends, which gives its length
    E; then env i, after a random number of steps in [0, E), steers to the action space's
    high corner (off the road, or for tasks without an off-road end until the time limit)
    until its episode ends and restarts. None of these steps is trained on."""
    n = envs.num_envs
    zeros = np.zeros(envs.action_space.shape, dtype=envs.action_space.dtype)
    corner = np.broadcast_to(envs.single_action_space.high, zeros.shape).astype(zeros.dtype)
    obs = None
    length = 0
    while length < limit:
        obs, _, terminated, truncated, _ = envs.step(zeros)
        length += 1
        if (terminated | truncated).any():
            break
    obs, *_ = envs.step(zeros)  # the ended envs reset here
    offsets = rng.integers(0, max(1, length), n)
    ended = np.zeros(n, dtype=bool)
    resetting = np.zeros(n, dtype=bool)
    for t in range(limit):
        if ended.all():
            break
        actions = np.where(((t >= offsets) & ~ended)[:, None], corner, zeros)
        obs, _, terminated, truncated, _ = envs.step(actions)
        ended |= (terminated | truncated) & ~resetting
        resetting = terminated | truncated
    return obs


class _Run:
    """One training run's state: rollouts, updates, checkpoints, the curve."""

    def __init__(
        self,
        cfg: TrainConfig,
        s: NativePpoSettings,
        envs: Any,
        model: Any,
        norm: Any,
        out: Path,
        progress: Progress | None,
        score: Any,
        t0: float,
    ) -> None:
        import torch

        self.cfg, self.s, self.envs, self.model, self.norm, self.out = cfg, s, envs, model, norm, out
        self.policy = model.policy
        self.policy.set_training_mode(False)
        self.optimizer = torch.optim.Adam(self.policy.parameters(), lr=s.learning_rate, eps=1e-5)
        self.progress, self.score = progress, score
        self.rng = np.random.default_rng(cfg.seed)
        self.n = cfg.n_envs
        self.rewards = _RewardScaler(norm.ret_rms, self.n, s.gamma, norm.clip_reward, norm.epsilon) if cfg.normalize_rewards else None
        self.start_steps = int(model.num_timesteps)
        self.episode_returns: list[float] = []
        self.curve: list[dict[str, Any]] = []
        self.t0 = t0  # (before the warm start: its time counts)
        self.update_s = 0.0  # of which in the policy updates
        self.eval_s = 0.0
        self.evaluations: list[tuple[int, list[float]]] = []
        self.last_metrics: dict[str, Any] = {}
        self.stopped_at: int | None = None
        self.frozen_obs = False  # after a warm start: the clone's inputs keep their scale
        self.eval_note = ""  # wall time spent evaluating checkpoints (in wall_s, not in train_s)

    # ---------------------------------------------------------------- helpers
    def _obs(self, obs: np.ndarray, update: bool) -> np.ndarray:
        if self.cfg.normalize_observations:
            if update and not self.frozen_obs:
                self.norm.obs_rms.update(obs)
            rms, clip = self.norm.obs_rms, self.norm.clip_obs
            obs = np.clip((obs - rms.mean) / np.sqrt(rms.var + self.norm.epsilon), -clip, clip)
        return obs.astype(np.float32)

    def _act(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        import torch

        with torch.no_grad():
            actions, values, log_prob = self.policy(torch.as_tensor(obs))
        return actions.numpy(), values.flatten().numpy(), log_prob.numpy()

    def _mean_action(self, raw_obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self.policy._predict(torch.as_tensor(self._obs(raw_obs[None], update=False)), deterministic=True).numpy()[0]  # type: ignore[no-any-return]

    def _value(self, obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self.policy.predict_values(torch.as_tensor(obs)).flatten().numpy()  # type: ignore[no-any-return]

    def warm_start(self, w: WarmStart) -> None:
        """Clone `w.driver` into the policy (`training.warm_start`) and score the clone: the
        curve's first row (steps 0)."""
        cfg = self.cfg
        env_id = cfg.env.split(":", 1)[-1]
        obs, actions, returns = demonstrations(env_id, dict(cfg.env_kwargs), w, cfg.seed)
        first_return = float(np.mean(returns))
        for r in range(w.dagger + 1):
            if r > 0:  # DAgger: the clone drives, the driver labels what it sees
                more_obs, more_actions, returns = demonstrations(env_id, dict(cfg.env_kwargs), w, cfg.seed + 100 * r, act=self._mean_action)
                obs, actions = np.concatenate([obs, more_obs]), np.concatenate([actions, more_actions])
            if cfg.normalize_observations and r == 0:
                self.norm.obs_rms.update(obs)
            loss = self._clone(self._obs(obs, update=False), actions, w, cfg.seed + r)
        self.frozen_obs = True
        self._cloned(obs, actions)
        checkpoint = self.out / "checkpoints" / f"model_{self.model.num_timesteps}_steps.zip"
        self._save(checkpoint, checkpoint=True)
        wall = time.perf_counter() - self.t0
        row: dict[str, Any] = {"steps": self.model.num_timesteps, "wall_s": round(wall, 2), "train_s": round(wall, 2), "update_s": 0.0}
        row.update(mean_return_last_10=first_return, warm_start_steps=len(obs), warm_start_clone_return=float(np.mean(returns)))
        row["warm_start_loss"] = round(loss, 5)
        row.update(self._evaluate(checkpoint))
        row["wall_s"] = round(time.perf_counter() - self.t0, 2)
        self.curve.append(row)
        self._write_curve()

    def _clone(self, obs: np.ndarray, actions: np.ndarray, w: WarmStart, seed: int) -> float:
        """One warm-start fit of the policy to the driver's actions (normalised `obs`)."""
        return clone(self.policy, obs, actions, w, seed)

    def _cloned(self, raw_obs: np.ndarray, actions: np.ndarray) -> None:
        """After the last DAgger round, before the clone is saved and scored (a learner that
        keeps the demonstrations takes them here)."""

    # ---------------------------------------------------------------- loop
    def learn(self) -> dict[str, Any]:
        cfg, s, n = self.cfg, self.s, self.n
        per_rollout = s.n_steps * n
        rollouts = max(1, math.ceil(cfg.total_steps / per_rollout))
        obs_raw, _ = self.envs.reset(seed=cfg.seed)
        if s.desync:
            obs_raw = desync(self.envs, self.rng)
        low, high = self.envs.single_action_space.low, self.envs.single_action_space.high
        resetting = np.zeros(n, dtype=bool)
        running = np.zeros(n)
        next_checkpoint = cfg.checkpoint_every_steps
        next_eval = cfg.eval_every_steps
        done_steps = 0
        obs_dim = int(np.prod(self.envs.single_observation_space.shape))
        act_dim = int(np.prod(self.envs.single_action_space.shape))
        for k in range(rollouts):
            if s.anneal_lr:
                for group in self.optimizer.param_groups:
                    group["lr"] = s.learning_rate * (1.0 - k / rollouts)
            b_obs = np.zeros((s.n_steps, n, obs_dim), dtype=np.float32)
            b_act = np.zeros((s.n_steps, n, act_dim), dtype=np.float32)
            b_logp = np.zeros((s.n_steps, n), dtype=np.float32)
            b_val = np.zeros((s.n_steps + 1, n), dtype=np.float32)
            b_rew = np.zeros((s.n_steps, n), dtype=np.float32)
            b_valid = np.zeros((s.n_steps, n), dtype=bool)
            b_term = np.zeros((s.n_steps, n), dtype=bool)
            b_end = np.zeros((s.n_steps, n), dtype=bool)
            obs = self._obs(obs_raw, update=True)
            for t in range(s.n_steps):
                actions, values, logp = self._act(obs)
                b_obs[t], b_act[t], b_logp[t], b_val[t], b_valid[t] = obs, actions, logp, values, ~resetting
                obs_raw, reward, terminated, truncated, _ = self.envs.step(np.clip(actions, low, high))
                ended = (terminated | truncated) & ~resetting
                valid = ~resetting
                running[valid] += reward[valid]
                self.episode_returns.extend(running[ended].tolist())
                running[ended] = 0.0
                b_rew[t] = self.rewards(reward, valid, ended) if self.rewards else reward
                b_term[t], b_end[t] = terminated & valid, ended
                resetting = terminated | truncated
                obs = self._obs(obs_raw, update=t + 1 < s.n_steps)
            b_val[s.n_steps] = self._value(obs)
            adv, ret = gae(b_rew, b_val, b_term, b_end, s.gamma, s.gae_lambda)
            started = time.perf_counter()
            self._update(b_obs[b_valid], b_act[b_valid], b_logp[b_valid], adv[b_valid], ret[b_valid], policy=k >= s.value_warmup)
            self.update_s += time.perf_counter() - started
            done_steps += per_rollout
            self.model.num_timesteps = self.start_steps + done_steps
            wall = time.perf_counter() - self.t0
            row: dict[str, Any] = {"steps": self.model.num_timesteps, "wall_s": round(wall, 2)}
            row.update(train_s=round(wall - self.eval_s, 2), update_s=round(self.update_s, 2))
            row["mean_return_last_10"] = float(np.mean(self.episode_returns[-10:])) if self.episode_returns else math.nan
            if done_steps >= next_checkpoint or k == rollouts - 1:
                next_checkpoint += cfg.checkpoint_every_steps
                self._save(self.out / "checkpoints" / f"model_{self.model.num_timesteps}_steps.zip", checkpoint=True)
            stop = False
            if done_steps >= next_eval and k < rollouts - 1:
                next_eval += cfg.eval_every_steps
                checkpoint = self.out / "checkpoints" / f"model_{self.model.num_timesteps}_steps.zip"
                if not checkpoint.is_file():
                    self._save(checkpoint, checkpoint=True)
                row.update(self._evaluate(checkpoint))
                stop = self._meets_stop_at(row)
            self.curve.append(row)
            if "eval_return" in row:  # (so far: a run stopped by hand keeps its curve)
                self._write_curve()
            if self.progress is not None:
                note = f"return {row['mean_return_last_10']:.1f}" if math.isfinite(row["mean_return_last_10"]) else ""
                evaluated = {k.removeprefix("eval_"): v for k, v in row.items() if k.startswith("eval_")}
                if evaluated:  # the evaluation of this step, shown until the next one
                    self.eval_note = "  eval " + " ".join(f"{k} {v:.4g}" for k, v in evaluated.items())
                note += self.eval_note
                self.progress(min(done_steps, cfg.total_steps), note)
            if stop:
                self.stopped_at = self.model.num_timesteps
                break
        self._save(self.out / "model.zip", checkpoint=False)
        if self.stopped_at is None:
            final = self._evaluate(self.out / "model.zip", full=True)
            self.curve[-1].update({k: v for k, v in final.items() if k != "full"})
            metrics = dict(final["full"])
        else:  # the evaluation that met `stop_at` scored this very model
            metrics = dict(self.last_metrics)
        metrics.update(total_steps=self.model.num_timesteps, wall_s=round(time.perf_counter() - self.t0, 2), stopped_at=self.stopped_at)
        (self.out / "metrics.json").write_text(json.dumps(json_safe(metrics), indent=2), encoding="utf-8")
        self._write_curve()
        return metrics

    def _meets_stop_at(self, row: dict[str, Any]) -> bool:
        """Whether the evaluation in `row` meets every bound of the config's `stop_at`."""
        bounds = self.cfg.stop_at
        return bool(bounds) and all(low <= row.get(f"eval_{k}", math.nan) <= high for k, (low, high) in bounds.items())

    def _update(self, obs: np.ndarray, act: np.ndarray, logp: np.ndarray, adv: np.ndarray, ret: np.ndarray, policy: bool = True) -> None:
        """PPO's clipped update; with `policy` false only the value function learns."""
        import torch

        s = self.s
        self.policy.set_training_mode(True)
        t_obs, t_act, t_logp = torch.as_tensor(obs), torch.as_tensor(act), torch.as_tensor(logp)
        t_adv, t_ret = torch.as_tensor(adv), torch.as_tensor(ret)
        size = len(obs)
        batch = min(s.batch_size, size)
        for _ in range(s.n_epochs):
            order = self.rng.permutation(size)
            kls = []
            for start in range(0, size - batch + 1, batch):
                idx = torch.as_tensor(order[start : start + batch])
                values, log_prob, entropy = self.policy.evaluate_actions(t_obs[idx], t_act[idx])
                a = t_adv[idx]
                a = (a - a.mean()) / (a.std() + 1e-8)
                ratio = torch.exp(log_prob - t_logp[idx])
                policy_loss = -torch.min(a * ratio, a * torch.clamp(ratio, 1 - s.clip_range, 1 + s.clip_range)).mean()
                value_loss = torch.nn.functional.mse_loss(t_ret[idx], values.flatten())
                entropy_loss = -torch.mean(entropy) if entropy is not None else -torch.mean(-log_prob)
                loss = policy_loss + s.ent_coef * entropy_loss + s.vf_coef * value_loss if policy else s.vf_coef * value_loss
                self.optimizer.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.policy.parameters(), s.max_grad_norm)
                self.optimizer.step()
                with torch.no_grad():
                    kls.append(float(torch.mean((ratio - 1) - torch.log(ratio))))
            if s.target_kl is not None and np.mean(kls) > 1.5 * s.target_kl:
                break
        self.policy.set_training_mode(False)

    # ---------------------------------------------------------------- outputs
    def _save(self, path: Path, checkpoint: bool) -> None:
        self.model.save(str(path))
        # beside the model, or where SB3's CheckpointCallback puts a checkpoint's (drivers.policy.normalizer_path)
        name = path.name.replace("model_", "model_vecnormalize_").removesuffix(".zip") + ".pkl" if checkpoint else "model.vecnormalize.pkl"
        stats = path.with_name(name)
        if self.cfg.normalize_observations or self.cfg.normalize_rewards:
            self.norm.save(str(stats))

    def _evaluate(self, model: Path, full: bool = False) -> dict[str, Any]:
        started = time.perf_counter()
        metrics = self.score(self.cfg, model)
        self.eval_s += time.perf_counter() - started
        self.last_metrics = metrics
        mean = metrics.get("mean", {})
        returns = [float(e.get("return", math.nan)) for e in metrics.get("episodes", [])]
        self.evaluations.append((self.model.num_timesteps, returns))
        row = {f"eval_{k}": v for k, v in mean.items() if k in (*EVAL_KEYS, *self.cfg.stop_at)}
        return {**row, "full": metrics} if full else row

    def _write_curve(self) -> None:
        if self.evaluations:  # as SB3's EvalCallback writes it (agents/plot_curves.py reads it)
            width = max(len(r) for _, r in self.evaluations)
            results = np.array([r + [math.nan] * (width - len(r)) for _, r in self.evaluations])
            np.savez(self.out / "evaluations.npz", timesteps=np.array([t for t, _ in self.evaluations]), results=results)
        keys: list[str] = []
        for row in self.curve:
            keys += [k for k in row if k not in keys]
        with (self.out / "curve.csv").open("w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=keys, restval="")
            w.writeheader()
            w.writerows(self.curve)


# the episode metrics a training curve records (the quality tests' keys; absent ones are skipped)
EVAL_KEYS = ("return", "lane_changes_correct", "mdev_basic_m", "stimuli", "stimulus_misses", "BrakeSign_correct", "collisions")
