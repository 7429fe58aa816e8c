"""Behaviour cloning from a Minari dataset: a small torch MLP regressed onto the recorded actions.

Why our own trainer: `imitation` pins older gymnasium and stable-baselines3 than ours. BC is
supervised regression (Pomerleau 1989, ALVINN; Bain and Sammut 1995): minimise the mean
squared error between the network's action and the driver's for every recorded observation.
Observations are standardised with the dataset's mean and standard deviation (saved with the
weights, `drivers.bc`; a feature constant in the data keeps its scale, and standardised values are
clipped to +-10 as stable-baselines3's VecNormalize clips them, so a new episode's features stay
in the range the network saw); actions are scaled to [-1, 1] from the action space's bounds and
standardised as well (a linear output layer; `drivers.bc.action_output` undoes it). CPU,
seeded, minibatches in a seeded order: the same dataset and seed give the same clone.

A driver's action often depends on more than what it sees now (a reaction delay, a stale
percept while the eyes are away, a wheel moved smoothly): `history` stacks the last observations
and `actions` adds the actions taken before them (`drivers.bc.stacked_inputs`, the same at run
time). A share `validation` of the episodes (whole episodes, seeded choice) is held out; the
weights of the epoch with the lowest held-out error are kept and training stops after `patience`
epochs without a better one (early stopping: a clone fitted ever closer to its demonstrations
drove worse, docs/imitation.md).

`ensemble` trains that many members from consecutive seeds on the same data and the clone acts
with their mean output: averaging independently initialised networks cancels much of the error
each makes away from its data (Breiman 1996, "Bagging predictors"; Lakshminarayanan et al. 2017,
"Simple and scalable predictive uncertainty estimation using deep ensembles"), and a clone of a
few short logs whose drive hinged on its training seed drives alike across seeds
(docs/imitation.md).
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..drivers.bc import CLIP, SETTINGS, WEIGHTS, build_mlp, stacked_inputs
from ..errors import UserError
from ..extras import require

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BCConfig:
    epochs: int = 30
    batch_size: int = 256
    lr: float = 1e-3
    hidden: tuple[int, ...] = (256, 256)
    seed: int = 0
    weight_decay: float = 0.0
    history: int = 1  # observations the network sees (the current one and history-1 before it)
    actions: bool = False  # the network also sees the actions taken before those observations
    validation: float = 0.1  # share of the episodes held out for early stopping (0: none, train all epochs)
    patience: int = 10  # epochs without a lower held-out error before training stops
    ensemble: int = 1  # members trained from seeds ensemble*seed + 0..ensemble-1 (no two seeds share one); it acts with their mean


def dataset_arrays(ds: Any, history: int = 1, actions: bool = False) -> list[tuple[np.ndarray, np.ndarray]]:
    """(inputs, actions) of each episode of a Minari dataset: the input of each step as
    `drivers.bc.stacked_inputs` builds it (the driver builds it the same way)."""
    out = []
    for ep in ds.iterate_episodes():
        o = np.asarray(ep.observations, dtype=np.float32)
        a = np.asarray(ep.actions, dtype=np.float32)
        if o.ndim != 2 or a.ndim != 2:
            raise UserError(f"{ds.id}: behaviour cloning needs vector observations and actions, got {o.shape[1:]} and {a.shape[1:]}")
        out.append((stacked_inputs(o[: len(a)], a, history, actions), a))
    if not out:
        raise UserError(f"{ds.id}: the dataset has no episodes")
    return out


def split(n: int, share: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Episode indices (train, held out): a seeded `share` of `n` episodes, at least one when
    share > 0 and there are two or more, never all."""
    held = min(n - 1, max(1, round(n * share))) if share > 0 and n > 1 else 0
    order = np.random.default_rng(seed).permutation(n)
    return np.sort(order[held:]), np.sort(order[:held])


# The env options that shape the observation a clone was trained on: its `--agent bc:` run makes
# the env with them (unless told otherwise), as `recover_environment()` does from the dataset.
CLONE_ENV_OPTIONS = ("road_preview_m",)


def clone_env_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The dataset env spec's observation-shaping options (JSON-able), those set only."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in kwargs.items() if k in CLONE_ENV_OPTIONS and v not in (None, (), [])}


def train_bc(dataset: str, out: str | Path, config: BCConfig = BCConfig()) -> dict[str, Any]:
    """Train a clone on Minari dataset `dataset`, save it in folder `out`; returns its summary."""
    if config.history < 1:
        raise UserError(f"history must be at least 1, not {config.history}")
    if config.ensemble < 1:
        raise UserError(f"ensemble must be at least 1 member, not {config.ensemble}")
    if not 0.0 <= config.validation < 1.0:
        raise UserError(f"validation must be a share in [0, 1), not {config.validation}")
    minari = require("data", "minari", "behaviour cloning from a Minari dataset")
    torch = require("rl", "torch", "behaviour cloning")
    try:
        ds = minari.load_dataset(dataset)
    except (FileNotFoundError, ValueError) as e:
        raise UserError(f"no Minari dataset {dataset!r} under MINARI_DATASETS_PATH: {e}") from None
    space = ds.action_space
    if not hasattr(space, "low"):
        raise UserError(f"{dataset}: behaviour cloning needs a Box action space, the dataset has {space}")
    episodes = dataset_arrays(ds, config.history, config.actions)
    train_idx, held_idx = split(len(episodes), config.validation, config.seed)
    obs = np.nan_to_num(np.concatenate([episodes[i][0] for i in train_idx]), posinf=0.0, neginf=0.0)
    mean = obs.mean(axis=0)
    std = obs.std(axis=0)
    std = np.where(std < 1e-6, 1.0, std)  # a feature constant in the data: no scale to learn from it
    low, high = np.asarray(space.low, dtype=np.float32), np.asarray(space.high, dtype=np.float32)

    def scaled(idx: np.ndarray) -> np.ndarray:
        a = np.concatenate([episodes[i][1] for i in idx])
        return np.clip(2.0 * (a - low) / (high - low) - 1.0, -1.0, 1.0)

    # actions standardised too: a driver's steering varies by ~0.01 of its range, its pedal far
    # more; on the bounds' scale the squared error, and so the fit, is all pedal
    train_target = scaled(train_idx)
    t_mean = train_target.mean(axis=0)
    t_std = train_target.std(axis=0)
    t_std = np.where(t_std < 1e-6, 1.0, t_std)

    def tensors(idx: np.ndarray) -> tuple[Any, Any]:
        o = np.nan_to_num(np.concatenate([episodes[i][0] for i in idx]), posinf=0.0, neginf=0.0)
        target = (scaled(idx) - t_mean) / t_std
        return torch.from_numpy(np.clip((o - mean) / std, -CLIP, CLIP).astype(np.float32)), torch.from_numpy(target.astype(np.float32))

    x, y = tensors(train_idx)
    del obs
    held = tensors(held_idx) if len(held_idx) else None
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a small MLP: one thread is ~10x faster than threads contending for busy cores
    try:
        with torch.random.fork_rng(devices=[]):  # seeded weights without moving the caller's torch RNG
            fits = [_fit(torch, x, y, held, replace(config, seed=config.seed * config.ensemble + m)) for m in range(config.ensemble)]
    finally:
        torch.set_num_threads(threads)
    net, losses, held_losses = fits[0]
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    # one member: its Sequential's state dict (as before ensembles); several: a ModuleList's (keys "m.layer...")
    state = net.state_dict() if config.ensemble == 1 else torch.nn.ModuleList([f[0] for f in fits]).state_dict()
    torch.save(state, folder / WEIGHTS)
    summary = {
        "dataset": ds.id,
        "env_id": ds.env_spec.id if ds.env_spec is not None else "",
        "env_kwargs": clone_env_kwargs(ds.env_spec.kwargs if ds.env_spec is not None else {}),
        "episodes": int(ds.total_episodes),
        "steps": int(len(x)),
        "held_out_episodes": len(held_idx),
        "final_mse": losses[-1] if losses else math.nan,
        "validation_mse": min(held_losses) if held_losses else math.nan,
        "best_epoch": int(np.argmin(held_losses)) + 1 if held_losses else len(losses),
        "member_final_mse": [f[1][-1] if f[1] else math.nan for f in fits],
        **{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()},
    }
    settings = {
        **summary,
        "obs_mean": mean.tolist(),
        "obs_std": std.tolist(),
        "action_low": low.tolist(),
        "action_high": high.tolist(),
        "target_mean": t_mean.tolist(),
        "target_std": t_std.tolist(),
    }
    (folder / SETTINGS).write_text(json.dumps(settings, indent=1), encoding="utf-8")
    return {**summary, "out": str(folder), "loss_per_epoch": losses, "validation_loss_per_epoch": held_losses}


def _fit(torch: Any, x: Any, y: Any, held: tuple[Any, Any] | None, config: BCConfig) -> tuple[Any, list[float], list[float]]:
    """Adam on the mean squared error, minibatches in a seeded order; the training loss of each
    epoch and, with held-out data, its loss there (the best epoch's weights are returned)."""
    gen = torch.Generator().manual_seed(config.seed)
    torch.manual_seed(config.seed)
    net = build_mlp(x.shape[1], y.shape[1], config.hidden, squash=False)
    opt = torch.optim.Adam(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    losses: list[float] = []
    held_losses: list[float] = []
    best = None
    for _ in range(config.epochs):
        order = torch.randperm(len(x), generator=gen)
        total = 0.0
        for i in range(0, len(x), config.batch_size):
            idx = order[i : i + config.batch_size]
            loss = torch.nn.functional.mse_loss(net(x[idx]), y[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        losses.append(total / len(x))
        if held is None:
            continue
        with torch.no_grad():
            held_losses.append(float(torch.nn.functional.mse_loss(net(held[0]), held[1])))
        log.info("epoch %d: training mse %.6f, held-out mse %.6f", len(losses), losses[-1], held_losses[-1])
        if held_losses[-1] <= min(held_losses):
            best = {k: v.clone() for k, v in net.state_dict().items()}
        elif len(held_losses) - 1 - int(np.argmin(held_losses)) >= config.patience:
            break
    if best is not None:
        net.load_state_dict(best)
    return net, losses, held_losses
