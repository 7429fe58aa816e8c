"""SAC on the native batch (`vec_env: native`, `algorithm: sac`), warm-started by cloning.

Why: SB3's SAC steps one env per Python call and makes one gradient step per env step; on
this two-core host that was too slow to retrain the LCT's SAC baseline. Here the envs are
one `NativeVectorEnv` (one call per batched step), the actor acts for all of them with one
torch call, and `gradient_steps` updates follow every `train_freq` batched steps.

A warm start (`warm_start:`, as the PPO configs use; `training.warm_start`) clones a driver
into the actor's mean (behaviour cloning with DAgger rounds) and sets its exploration noise;
then the clone drives the batch with that noise for `learning_starts` env steps, filling the
replay buffer, the critics learn alone for `critic_warmup` gradient steps (so the actor's
first updates do not follow an untrained Q), and SAC (Haarnoja et al. 2018) fine-tunes
actor, critics and, with `ent_coef: auto`, the entropy coefficient.

The policy is SB3's own `SACPolicy` inside a `stable_baselines3.SAC` object, updated as
SB3's `SAC.train` does, and the normaliser an SB3 `VecNormalize`: `model.zip` and
`model.vecnormalize.pkl` load with `--agent sac:PATH` and `SAC.load`. Run folder, curve,
checkpoints, evaluations and `stop_at` as in `training.native_ppo`; `curve.csv` has a row
every `CURVE_EVERY` env steps and at each evaluation.

The batch autoresets on the next step (its reward 0, its action ignored): that step is no
transition and is not stored. A terminated episode's last transition has no bootstrap
value; a truncated one's is worth the value of its last observation.

`--resume` loads the model and normaliser; the replay buffer starts empty and the warm
start's demonstrations (the `bc_coef` term) are not saved, so a resumed run is plain SAC.

Deterministic for a seed on one machine (envs seeded `seed + i`, torch seeded, one torch
thread by default, minibatches from a numpy generator seeded with `seed`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..extras import require
from .config import TrainConfig
from .native_ppo import NativePpoSettings, Progress, _normalizer, _Run, _Spaces, desync
from .warm_start import WarmStart, fit_mean

CURVE_EVERY = 8192  # env steps between the curve's rows


@dataclass(frozen=True)
class NativeSacSettings:
    """The `hyperparameters:` of a native SAC run (SB3's names where SB3 has them)."""

    buffer_size: int = 1_000_000  # transitions
    learning_starts: int = 10_000  # env steps before the first update (random actions unless warm-started)
    batch_size: int = 256
    learning_rate: float = 3e-4
    actor_learning_rate: float | None = None  # the actor's own (None: learning_rate)
    gamma: float = 0.99
    tau: float = 0.005
    train_freq: int = 1  # batched steps (n_envs env steps each) between updates
    gradient_steps: int = 1  # per update
    ent_coef: float | str = "auto"  # a number, "auto" or "auto_<initial value>" (SB3's)
    target_entropy: float | str = "auto"  # "auto": -(action dimensions)
    critic_warmup: int = 0  # gradient steps on the critics alone before the first SAC update
    bc_coef: float = 0.0  # > 0: the actor also regresses onto the warm start's demonstrations (see `_sac_update`)
    desync: bool = True  # spread the envs over the episode first (native_ppo.desync)
    torch_threads: int = 1

    @staticmethod
    def from_block(path_hint: str, block: dict[str, Any]) -> NativeSacSettings:
        names = {f.name for f in fields(NativeSacSettings)}
        unknown = sorted(set(block) - names)
        if unknown:
            valid = ", ".join(sorted(names))
            raise ValueError(f"{path_hint}hyperparameters: unknown key(s) {', '.join(unknown)} for vec_env native sac; valid keys: {valid}")
        s = NativeSacSettings(**block)
        for key in ("buffer_size", "batch_size", "train_freq", "gradient_steps", "torch_threads"):
            if int(getattr(s, key)) <= 0:
                raise ValueError(f"{path_hint}hyperparameters: {key} must be positive, not {getattr(s, key)!r}")
        for key in ("learning_starts", "critic_warmup", "bc_coef"):
            if int(getattr(s, key)) < 0:
                raise ValueError(f"{path_hint}hyperparameters: {key} must be >= 0, not {getattr(s, key)!r}")
        return s


class Replay:
    """A ring buffer of raw transitions (observations normalised when sampled, so a
    normaliser that still learns applies its latest statistics)."""

    def __init__(self, size: int, obs_dim: int, act_dim: int) -> None:
        self.size, self.n, self.at = size, 0, 0
        self.obs = np.zeros((size, obs_dim), dtype=np.float32)
        self.next_obs = np.zeros((size, obs_dim), dtype=np.float32)
        self.act = np.zeros((size, act_dim), dtype=np.float32)
        self.rew = np.zeros(size, dtype=np.float32)
        self.term = np.zeros(size, dtype=np.float32)

    def add(self, obs: np.ndarray, act: np.ndarray, rew: np.ndarray, next_obs: np.ndarray, term: np.ndarray) -> None:
        for i in range(len(obs)):  # (a batch is far smaller than the buffer: at most one wrap)
            j = self.at
            self.obs[j], self.act[j], self.rew[j], self.next_obs[j], self.term[j] = obs[i], act[i], rew[i], next_obs[i], term[i]
            self.at = (j + 1) % self.size
        self.n = min(self.size, self.n + len(obs))

    def sample(self, rng: np.random.Generator, k: int) -> tuple[np.ndarray, ...]:
        idx = rng.integers(0, self.n, k)
        return self.obs[idx], self.act[idx], self.rew[idx], self.next_obs[idx], self.term[idx]


def clone_actor(actor: Any, obs: np.ndarray, actions: np.ndarray, w: WarmStart, seed: int) -> float:
    """Regress the SAC actor's squashed mean action (tanh of its mean) onto `actions` (in the
    squashed [-1, 1] scale) for the normalised `obs`; returns the last epoch's mean squared
    error. `w.log_std` then sets the actor's exploration noise (its log-std head's output)."""
    import torch

    params = [*actor.features_extractor.parameters(), *actor.latent_pi.parameters(), *actor.mu.parameters()]
    loss_sum = fit_mean(
        actor,
        params,
        lambda x: torch.tanh(actor.mu(actor.latent_pi(actor.extract_features(x, actor.features_extractor)))),
        obs,
        actions,
        w,
        seed,
    )
    if w.log_std is not None:
        with torch.no_grad():
            head = actor.log_std
            head.weight.zero_()
            head.bias.copy_(torch.as_tensor(np.broadcast_to(np.asarray(w.log_std, dtype=np.float32), head.bias.shape).copy()))
    return loss_sum


def train(
    cfg: TrainConfig,
    base_dir: Path,
    out_dir: Path | None = None,
    resume: Path | None = None,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Train per `cfg` with SAC on the native batch; returns the final evaluation (also in
    `metrics.json`)."""
    for module in ("stable_baselines3", "torch"):
        require("rl", module, "opends-gym train")
    import torch
    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import VecNormalize

    from .sb3 import evaluate_policy_file

    if cfg.algorithm != "sac":
        raise ValueError(f"native_sac trains algorithm 'sac', not {cfg.algorithm!r}")
    s = NativeSacSettings.from_block("", dict(cfg.hyperparameters))
    warm = WarmStart.from_block("", dict(cfg.warm_start)) if cfg.warm_start and resume is None else None
    out = out_dir or cfg.output_dir(base_dir)
    (out / "checkpoints").mkdir(parents=True, exist_ok=True)
    env_id = cfg.env.split(":", 1)[-1]
    envs = gym.make_vec(env_id, num_envs=cfg.n_envs, vectorization_mode="vector_entry_point", record_metrics=False, **cfg.env_kwargs)
    space = envs.single_action_space
    if not isinstance(space, gym.spaces.Box) or not (np.all(space.low == -1) and np.all(space.high == 1)):
        raise ValueError(f"{cfg.env}: native SAC needs a Box action space in [-1, 1], not {space}")
    threads = torch.get_num_threads()
    torch.set_num_threads(s.torch_threads)
    torch.manual_seed(cfg.seed)
    try:
        stub = _Spaces(envs).venv
        if resume is not None:
            if not (resume / "model.zip").is_file():
                raise ValueError(f"nothing to resume: no model.zip in {resume}")
            model = SAC.load(str(resume / "model.zip"), device="cpu")
            stats = resume / "model.vecnormalize.pkl"
            fresh = _normalizer(stub, s.gamma, cfg.normalize_observations, False)
            norm = VecNormalize.load(str(stats), stub) if stats.is_file() else fresh
        else:
            sb3_keys: dict[str, Any] = dict(learning_rate=s.learning_rate, batch_size=s.batch_size, tau=s.tau, gamma=s.gamma)
            sb3_keys.update(ent_coef=s.ent_coef, target_entropy=s.target_entropy, buffer_size=1, learning_starts=0)
            model = SAC(cfg.policy, stub, seed=cfg.seed, policy_kwargs=dict(cfg.policy_kwargs), device="cpu", **sb3_keys)
            norm = _normalizer(stub, s.gamma, cfg.normalize_observations, False)
        score = lambda c, m: evaluate_policy_file(c, m, episodes=c.eval_episodes)  # noqa: E731
        run = _SacRun(cfg, s, envs, model, norm, out, progress, score, time.perf_counter())
        run.frozen_obs = bool(cfg.warm_start)
        if warm is not None:
            run.warm_start(warm)
        return run.learn()
    finally:
        envs.close()
        torch.set_num_threads(threads)


class _SacRun(_Run):
    """One native SAC run: native_ppo's run folder, evaluations and curve, SAC's loop."""

    def __init__(self, cfg: TrainConfig, s: NativeSacSettings, *args: Any) -> None:
        super().__init__(cfg, NativePpoSettings(gamma=s.gamma), *args)  # (its PPO settings are unused)
        self.sac = s
        self.rewards = None
        self.demo_obs: np.ndarray | None = None  # the warm start's normalised observations and the driver's actions
        self.demo_act: np.ndarray | None = None
        if s.actor_learning_rate is not None:
            for group in self.model.actor.optimizer.param_groups:
                group["lr"] = s.actor_learning_rate
        self.warm = False

    def _mean_action(self, raw_obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            obs = torch.as_tensor(self._obs(raw_obs[None], update=False))
            return self.model.actor(obs, deterministic=True).numpy()[0]  # type: ignore[no-any-return]

    def _clone(self, obs: np.ndarray, actions: np.ndarray, w: WarmStart, seed: int) -> float:
        """One warm-start fit of the actor (the DAgger rounds are `_Run.warm_start`'s)."""
        return clone_actor(self.model.actor, obs, actions, w, seed)

    def _cloned(self, raw_obs: np.ndarray, actions: np.ndarray) -> None:
        """Keep the demonstrations for the actor's behaviour-cloning term (`bc_coef`)."""
        self.warm = True
        self.demo_obs, self.demo_act = self._obs(raw_obs, update=False), actions.astype(np.float32)

    # ---------------------------------------------------------------- loop
    def learn(self) -> dict[str, Any]:
        cfg, s, n = self.cfg, self.sac, self.n
        obs_dim = int(np.prod(self.envs.single_observation_space.shape))
        act_dim = int(np.prod(self.envs.single_action_space.shape))
        buffer = Replay(s.buffer_size, obs_dim, act_dim)
        obs_raw, _ = self.envs.reset(seed=cfg.seed)
        if s.desync:
            obs_raw = desync(self.envs, self.rng)
        if cfg.normalize_observations and not self.frozen_obs:
            self.norm.obs_rms.update(obs_raw)
        resetting = np.zeros(n, dtype=bool)
        running = np.zeros(n)
        next_checkpoint, next_eval, next_row = cfg.checkpoint_every_steps, cfg.eval_every_steps, CURVE_EVERY
        done_steps, batched, updates = 0, 0, 0
        warmed_critics = s.critic_warmup == 0
        total = math.ceil(cfg.total_steps / n) * n
        while done_steps < total:
            if done_steps < s.learning_starts and not self.warm and self.start_steps == 0:
                actions = self.rng.uniform(-1.0, 1.0, (n, act_dim)).astype(np.float32)
            else:
                actions = self._sample(self._obs(obs_raw, update=False))
            next_raw, reward, terminated, truncated, _ = self.envs.step(actions)
            valid = ~resetting
            ended = (terminated | truncated) & valid
            buffer.add(obs_raw[valid], actions[valid], reward[valid], next_raw[valid], (terminated & valid)[valid])
            running[valid] += reward[valid]
            self.episode_returns.extend(running[ended].tolist())
            running[ended] = 0.0
            resetting = terminated | truncated
            obs_raw = next_raw
            if cfg.normalize_observations and not self.frozen_obs:
                self.norm.obs_rms.update(obs_raw[~resetting])
            done_steps += n
            batched += 1
            self.model.num_timesteps = self.start_steps + done_steps
            if done_steps >= s.learning_starts and buffer.n >= s.batch_size:
                started = time.perf_counter()
                if not warmed_critics:
                    self._sac_update(buffer, s.critic_warmup, actor=False)
                    warmed_critics = True
                if batched % s.train_freq == 0:
                    self._sac_update(buffer, s.gradient_steps)
                    updates += s.gradient_steps
                self.update_s += time.perf_counter() - started
            last = done_steps >= total
            if done_steps >= next_checkpoint or last:
                next_checkpoint += cfg.checkpoint_every_steps
                self._save(self.out / "checkpoints" / f"model_{self.model.num_timesteps}_steps.zip", checkpoint=True)
            evaluate = done_steps >= next_eval and not last
            if not (evaluate or done_steps >= next_row or last):
                continue
            next_row += CURVE_EVERY * (1 + (done_steps - next_row) // CURVE_EVERY) if done_steps >= next_row else 0
            wall = time.perf_counter() - self.t0
            row: dict[str, Any] = {"steps": self.model.num_timesteps, "wall_s": round(wall, 2)}
            row.update(train_s=round(wall - self.eval_s, 2), update_s=round(self.update_s, 2), gradient_steps=updates)
            row["mean_return_last_10"] = float(np.mean(self.episode_returns[-10:])) if self.episode_returns else math.nan
            row["ent_coef"] = round(self._ent_coef(), 6)
            stop = False
            if evaluate:
                next_eval += cfg.eval_every_steps
                checkpoint = self.out / "checkpoints" / f"model_{self.model.num_timesteps}_steps.zip"
                if not checkpoint.is_file():
                    self._save(checkpoint, checkpoint=True)
                row.update(self._evaluate(checkpoint))
                stop = self._meets_stop_at(row)
            self.curve.append(row)
            self._write_curve()
            if self.progress is not None:
                note = f"return {row['mean_return_last_10']:.1f}" if math.isfinite(row["mean_return_last_10"]) else ""
                evaluated = {k.removeprefix("eval_"): v for k, v in row.items() if k.startswith("eval_")}
                if evaluated:
                    self.eval_note = "  eval " + " ".join(f"{k} {v:.4g}" for k, v in evaluated.items())
                self.progress(min(done_steps, cfg.total_steps), note + self.eval_note)
            if stop:
                self.stopped_at = self.model.num_timesteps
                break
        return self._finish()

    def _finish(self) -> dict[str, Any]:
        import json

        from ..jsonsafe import json_safe

        self._save(self.out / "model.zip", checkpoint=False)
        if self.stopped_at is None:
            final = self._evaluate(self.out / "model.zip", full=True)
            self.curve[-1].update({k: v for k, v in final.items() if k != "full"})
            metrics = dict(final["full"])
        else:
            metrics = dict(self.last_metrics)
        metrics.update(total_steps=self.model.num_timesteps, wall_s=round(time.perf_counter() - self.t0, 2), stopped_at=self.stopped_at)
        (self.out / "metrics.json").write_text(json.dumps(json_safe(metrics), indent=2), encoding="utf-8")
        self._write_curve()
        return metrics

    def _sample(self, obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self.model.actor(torch.as_tensor(obs)).numpy()  # type: ignore[no-any-return]

    def _ent_coef(self) -> float:
        m = self.model
        return float(m.log_ent_coef.detach().exp()) if m.ent_coef_optimizer is not None else float(m.ent_coef_tensor)

    def _bc_loss(self, idx: np.ndarray) -> Any:
        """Mean squared error of the actor's squashed mean action from the driver's on
        demonstrations `idx`."""
        import torch

        assert self.demo_obs is not None and self.demo_act is not None
        actor = self.model.actor
        obs = torch.as_tensor(self.demo_obs[idx])
        mean = torch.tanh(actor.mu(actor.latent_pi(actor.extract_features(obs, actor.features_extractor))))
        return torch.nn.functional.mse_loss(mean, torch.as_tensor(self.demo_act[idx]))

    def _sac_update(self, buffer: Replay, steps: int, actor: bool = True) -> None:
        """`steps` gradient steps of SB3's `SAC.train` (critics, actor, entropy coefficient,
        Polyak-averaged target critics); with `actor` false only the critics learn.

        With `bc_coef` > 0 after a warm start the actor's loss is TD3+BC's (Fujimoto and Gu
        2021) with SAC's entropy term: SAC's actor loss divided by the mean |Q| of the batch
        (so `bc_coef` does not depend on the reward's scale) plus `bc_coef` times the squared
        error of the mean action from the driver's on a minibatch of the warm start's
        demonstrations (as Nair et al. 2018 add a behaviour-cloning loss to DDPG's actor).
        Why: unregularised, SAC's actor followed its critics' action gradients away from the
        clone (on the LCT from 18/18 lane changes to 4/18 in 25k env steps, with an actor
        learning rate of 1e-5), where the LCT needs steering precise to hundredths of a rad."""
        import torch
        from stable_baselines3.common.utils import polyak_update

        m, s = self.model, self.sac
        m.policy.set_training_mode(True)
        for _ in range(steps):
            o, a, r, o2, term = buffer.sample(self.rng, s.batch_size)
            obs, next_obs = torch.as_tensor(self._obs(o, update=False)), torch.as_tensor(self._obs(o2, update=False))
            act, rew, done = torch.as_tensor(a), torch.as_tensor(r)[:, None], torch.as_tensor(term)[:, None]
            pi, log_prob = m.actor.action_log_prob(obs)
            log_prob = log_prob.reshape(-1, 1)
            if m.ent_coef_optimizer is not None:
                ent_coef = torch.exp(m.log_ent_coef.detach())
                if actor:
                    ent_loss = -(m.log_ent_coef * (log_prob + m.target_entropy).detach()).mean()
                    m.ent_coef_optimizer.zero_grad()
                    ent_loss.backward()
                    m.ent_coef_optimizer.step()
            else:
                ent_coef = m.ent_coef_tensor
            with torch.no_grad():
                next_pi, next_log_prob = m.actor.action_log_prob(next_obs)
                next_q = torch.min(torch.cat(m.critic_target(next_obs, next_pi), dim=1), dim=1, keepdim=True).values
                target = rew + (1 - done) * s.gamma * (next_q - ent_coef * next_log_prob.reshape(-1, 1))
            critic_loss = 0.5 * sum(torch.nn.functional.mse_loss(q, target) for q in m.critic(obs, act))
            m.critic.optimizer.zero_grad()
            critic_loss.backward()  # type: ignore[union-attr]
            m.critic.optimizer.step()
            if actor:
                q_pi = torch.min(torch.cat(m.critic(obs, pi), dim=1), dim=1, keepdim=True).values
                actor_loss = (ent_coef * log_prob - q_pi).mean()
                if s.bc_coef > 0 and self.demo_obs is not None and self.demo_act is not None:
                    idx = self.rng.integers(0, len(self.demo_obs), s.batch_size)
                    actor_loss = actor_loss / q_pi.abs().mean().detach().clamp(min=1e-3) + s.bc_coef * self._bc_loss(idx)
                m.actor.optimizer.zero_grad()
                actor_loss.backward()
                m.actor.optimizer.step()
            polyak_update(m.critic.parameters(), m.critic_target.parameters(), s.tau)
        m.policy.set_training_mode(False)
