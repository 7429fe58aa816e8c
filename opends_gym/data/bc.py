"""Behaviour cloning from a Minari dataset: a small torch MLP regressed onto the recorded actions.

Why our own trainer: `imitation` pins older gymnasium and stable-baselines3 than ours. BC is
supervised regression (Pomerleau 1989, ALVINN; Bain and Sammut 1995): minimise the mean
squared error between the network's action and the driver's for every recorded observation.
Observations are standardised with the dataset's mean and standard deviation (saved with the
weights, `drivers.bc`; a feature constant in the data keeps its scale, and standardised values are
clipped to +-10 as stable-baselines3's VecNormalize clips them, so a new episode's features stay
in the range the network saw); actions are scaled to [-1, 1] from the action space's bounds. CPU,
seeded, full-batch order from a seeded permutation: the same dataset and seed give the same clone.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..drivers.bc import CLIP, SETTINGS, WEIGHTS, build_mlp, stack
from ..errors import UserError
from ..extras import require


@dataclass(frozen=True)
class BCConfig:
    epochs: int = 30
    batch_size: int = 256
    lr: float = 1e-3
    hidden: tuple[int, ...] = (256, 256)
    seed: int = 0
    weight_decay: float = 0.0
    history: int = 1  # observations the network sees (the current one and history-1 before it)


def dataset_arrays(ds: Any, history: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(observations, actions) of every step of a Minari dataset (the observation each action was
    taken at, with the `history - 1` before it as `drivers.bc.stack` stacks them)."""
    obs, act = [], []
    for ep in ds.iterate_episodes():
        o = np.asarray(ep.observations, dtype=np.float32)
        a = np.asarray(ep.actions, dtype=np.float32)
        if o.ndim != 2 or a.ndim != 2:
            raise UserError(f"{ds.id}: behaviour cloning needs vector observations and actions, got {o.shape[1:]} and {a.shape[1:]}")
        frames = [o[i] for i in range(len(a))]
        obs.append(np.asarray([stack(frames[: i + 1], history) for i in range(len(a))]) if history > 1 else o[: len(a)])
        act.append(a)
    if not obs:
        raise UserError(f"{ds.id}: the dataset has no episodes")
    return np.concatenate(obs), np.concatenate(act)


def train_bc(dataset: str, out: str | Path, config: BCConfig = BCConfig()) -> dict[str, Any]:
    """Train a clone on Minari dataset `dataset`, save it in folder `out`; returns its summary."""
    minari = require("data", "minari", "behaviour cloning from a Minari dataset")
    torch = require("rl", "torch", "behaviour cloning")
    try:
        ds = minari.load_dataset(dataset)
    except (FileNotFoundError, ValueError) as e:
        raise UserError(f"no Minari dataset {dataset!r} under MINARI_DATASETS_PATH: {e}") from None
    space = ds.action_space
    if not hasattr(space, "low"):
        raise UserError(f"{dataset}: behaviour cloning needs a Box action space, the dataset has {space}")
    if config.history < 1:
        raise UserError(f"history must be at least 1, not {config.history}")
    obs, act = dataset_arrays(ds, config.history)
    obs = np.nan_to_num(obs, posinf=0.0, neginf=0.0)
    mean = obs.mean(axis=0)
    std = obs.std(axis=0)
    std = np.where(std < 1e-6, 1.0, std)  # a feature constant in the data: no scale to learn from it
    low, high = np.asarray(space.low, dtype=np.float32), np.asarray(space.high, dtype=np.float32)
    target = np.clip(2.0 * (act - low) / (high - low) - 1.0, -1.0, 1.0)
    x = torch.from_numpy(np.clip((obs - mean) / std, -CLIP, CLIP).astype(np.float32))
    y = torch.from_numpy(target.astype(np.float32))
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a small MLP: one thread is ~10x faster than threads contending for busy cores
    try:
        with torch.random.fork_rng(devices=[]):  # seeded weights without moving the caller's torch RNG
            net, losses = _fit(torch, x, y, config)
    finally:
        torch.set_num_threads(threads)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    torch.save(net.state_dict(), folder / WEIGHTS)
    summary = {
        "dataset": ds.id,
        "env_id": ds.env_spec.id if ds.env_spec is not None else "",
        "episodes": int(ds.total_episodes),
        "steps": int(len(x)),
        "final_mse": losses[-1] if losses else math.nan,
        **{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()},
    }
    settings = {
        **summary,
        "obs_mean": mean.tolist(),
        "obs_std": std.tolist(),
        "action_low": low.tolist(),
        "action_high": high.tolist(),
    }
    (folder / SETTINGS).write_text(json.dumps(settings, indent=1), encoding="utf-8")
    return {**summary, "out": str(folder), "loss_per_epoch": losses}


def _fit(torch: Any, x: Any, y: Any, config: BCConfig) -> tuple[Any, list[float]]:
    """Adam on the mean squared error, minibatches in a seeded order; the loss of each epoch."""
    gen = torch.Generator().manual_seed(config.seed)
    torch.manual_seed(config.seed)
    net = build_mlp(x.shape[1], y.shape[1], config.hidden)
    opt = torch.optim.Adam(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    losses = []
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
    return net, losses
