"""Warm start by behaviour cloning: a native PPO run's policy first imitates a driver.

Why: on the brake and platoon tests PPO from a random policy settled on stopping the car.
Before a policy can keep OpenDS's car on the road at 70-80 km/h behind a lead car, every
drive it tries ends early in a -50 penalty (off the road, into the lead car, past it),
while standing still costs only the capped band deviation (-0.1 a step); the first
policies that stop are the best ones seen, and the rollouts never find the +0.2 a step that
driving on pays. Cloning the rule driver (`opends_gym.drivers.rule`, which passes both
tests) first puts the policy where driving on pays, and PPO improves it from there: a
warm start by behaviour cloning (Pomerleau 1989; as in DAPG, Rajeswaran et al. 2018, and
AlphaStar's supervised start) instead of a reward changed to the task's detriment.

How: `episodes` drives of the config's env (seeds 10000, 10001, ...) by `driver` (an
`--agent` spec) are recorded; with `noise` > 0 the actions executed get Gaussian noise
while the driver's own action is the one recorded (DART, Laskey et al. 2017: the clone sees
how the driver recovers from the small errors it will make itself). The observation
normaliser is fitted on the recorded observations and the policy's mean action regressed
onto the recorded actions (mean squared error, Adam, seeded minibatches); the value function
then learns for `value_warmup` rollouts (`NativePpoSettings`) before PPO moves the policy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import gymnasium as gym
import numpy as np


@dataclass(frozen=True)
class WarmStart:
    """The `warm_start:` block of a native PPO config."""

    driver: str = "rule"  # an --agent spec
    episodes: int = 4
    noise: float | list[float] = 0.0  # std of the noise on the executed actions (action-space units; one or per dimension)
    epochs: int = 30
    batch_size: int = 256
    learning_rate: float = 1e-3
    dagger: int = 0  # rounds in which the clone drives and the driver labels (Ross et al. 2011)
    log_std: float | list[float] | None = None  # the policy's log std after cloning (one or per dimension; None: policy_kwargs')

    @staticmethod
    def from_block(path_hint: str, block: dict[str, Any]) -> WarmStart:
        names = {f.name for f in fields(WarmStart)}
        unknown = sorted(set(block) - names)
        if unknown:
            raise ValueError(f"{path_hint}warm_start: unknown key(s) {', '.join(unknown)}; valid keys: {', '.join(sorted(names))}")
        w = WarmStart(**block)
        if int(w.dagger) < 0:
            raise ValueError(f"{path_hint}warm_start: dagger must be >= 0, not {w.dagger!r}")
        for key in ("episodes", "epochs", "batch_size"):
            if int(getattr(w, key)) <= 0:
                raise ValueError(f"{path_hint}warm_start: {key} must be positive, not {getattr(w, key)!r}")
        if np.any(np.asarray(w.noise, dtype=float) < 0):
            raise ValueError(f"{path_hint}warm_start: noise must be >= 0, not {w.noise!r}")
        return w


def demonstrations(
    env_id: str, env_kwargs: dict[str, Any], w: WarmStart, seed: int, act: Callable[[np.ndarray], np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """(observations, the driver's actions, the returns) of `w.episodes` drives of `env_id`
    (seeds 10000 + seed + 100 x round, ...): driven by the driver (its actions plus
    `w.noise`), or by `act` (observation -> action, the clone: DAgger) with the driver
    only naming the action it would take."""
    from ..drivers.agents import make_agent

    env = gym.make(env_id, **env_kwargs)
    agent = make_agent(w.driver)
    space = env.action_space
    assert isinstance(space, gym.spaces.Box), "a warm start needs a continuous (Box) action space"
    rng = np.random.default_rng(seed)
    noise = np.broadcast_to(np.asarray(w.noise, dtype=np.float32), space.shape)
    obs_out: list[np.ndarray] = []
    act_out: list[np.ndarray] = []
    returns: list[float] = []
    try:
        for e in range(w.episodes):
            obs, info = env.reset(seed=10_000 + seed + e)
            agent.reset(env, 10_000 + seed + e)
            ret = 0.0
            while True:
                action = np.clip(np.asarray(agent.act(obs, info), dtype=np.float32), space.low, space.high)
                obs_out.append(np.asarray(obs, dtype=np.float32))
                act_out.append(action)
                executed = act(obs) if act is not None else action + noise * rng.standard_normal(action.shape).astype(np.float32)
                obs, reward, terminated, truncated, info = env.step(np.clip(executed, space.low, space.high))
                ret += float(reward)
                if terminated or truncated:
                    break
            returns.append(ret)
    finally:
        env.close()
    return np.stack(obs_out), np.stack(act_out), returns


def fit_mean(
    module: Any, params: list[Any], mean_of: Callable[[Any], Any], obs: np.ndarray, actions: np.ndarray, w: WarmStart, seed: int
) -> float:
    """Regress `mean_of(obs batch)` (a policy's mean action) onto `actions` by Adam over
    `params`, `w.epochs` shuffled epochs; returns the final epoch's mean squared error. Shared
    by PPO's `clone` and SAC's `native_sac.clone_actor`."""
    import torch

    x, y = torch.as_tensor(obs, dtype=torch.float32), torch.as_tensor(actions, dtype=torch.float32)
    optimizer = torch.optim.Adam(params, lr=w.learning_rate)
    rng = np.random.default_rng(seed)
    module.set_training_mode(True)
    loss_sum = 0.0
    for _ in range(w.epochs):
        order = rng.permutation(len(x))
        loss_sum, batches = 0.0, 0
        for start in range(0, len(x), w.batch_size):
            idx = torch.as_tensor(order[start : start + w.batch_size])
            loss = torch.nn.functional.mse_loss(mean_of(x[idx]), y[idx])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            loss_sum, batches = loss_sum + float(loss.detach()), batches + 1
        loss_sum /= max(1, batches)
    module.set_training_mode(False)
    return loss_sum


def clone(policy: Any, obs: np.ndarray, actions: np.ndarray, w: WarmStart, seed: int) -> float:
    """Regress `policy`'s mean action onto `actions` for the (already normalised) `obs`;
    returns the final epoch's mean squared error."""
    import torch

    params = [p for name, p in policy.named_parameters() if not name.startswith(("value_net", "mlp_extractor.value_net", "log_std"))]
    loss_sum = fit_mean(
        policy,
        params,
        lambda x: policy.action_net(policy.mlp_extractor.forward_actor(policy.extract_features(x, policy.pi_features_extractor))),
        obs,
        actions,
        w,
        seed,
    )
    if w.log_std is not None:
        with torch.no_grad():
            policy.log_std.copy_(torch.as_tensor(np.broadcast_to(np.asarray(w.log_std, dtype=np.float32), policy.log_std.shape).copy()))
    return loss_sum
