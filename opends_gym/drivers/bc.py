"""A behaviour-cloned driver: a small torch MLP from observation to action (`--agent bc:NAME`).

Why here: every agent spec resolves in `drivers.agents`, so a clone drives `run`, studies and
benchmarks like any other driver. The network and its file format live beside the driver;
`opends_gym.data.bc` trains it. A saved clone is a folder with `bc.pt` (the weights) and
`bc.json` (sizes, observation normalisation, action bounds, the env and dataset it came from,
`history`: how many recent observations the network sees, oldest first, `actions`: whether
it also sees the actions it took before each of them, and `ensemble`: how many networks `bc.pt`
holds, whose outputs the clone averages; a driver who answers a sign a second
later, acts on a stale percept during a glance or moves the wheel smoothly has state the
current observation does not show, and a memoryless clone acts the moment it sees a sign).
NAME is that folder (or its `bc.pt`) or a bundled policy folder of that name.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..extras import require
from ..resources import ResourceNotFound, policies_dir

WEIGHTS, SETTINGS = "bc.pt", "bc.json"
CLIP = 10.0  # standardised observations are clipped to +-CLIP (as stable-baselines3's VecNormalize)


def build_mlp(obs_dim: int, act_dim: int, hidden: tuple[int, ...], squash: bool = True) -> Any:
    """tanh MLP. `squash`: its output, in [-1, 1], is the action scaled onto the bounds (clones
    saved without `target_std`); else a linear output, the standardised action (`action_output`)."""
    torch = require("rl", "torch", "the behaviour-cloned driver")
    layers: list[Any] = []
    last = obs_dim
    for h in hidden:
        layers += [torch.nn.Linear(last, h), torch.nn.Tanh()]
        last = h
    layers += [torch.nn.Linear(last, act_dim)] + ([torch.nn.Tanh()] if squash else [])
    return torch.nn.Sequential(*layers)


def action_output(y: np.ndarray, settings: dict[str, Any]) -> np.ndarray:
    """The action for network output `y`: un-standardised (`target_mean`, `target_std`) where the
    clone learnt standardised actions, then mapped from [-1, 1] onto the action bounds."""
    if "target_std" in settings:
        y = np.clip(y * np.asarray(settings["target_std"]) + np.asarray(settings["target_mean"]), -1.0, 1.0)
    low, high = np.asarray(settings["action_low"]), np.asarray(settings["action_high"])
    return (low + (y + 1.0) * 0.5 * (high - low)).astype(np.float32)


def stack(history: list[np.ndarray], n: int) -> np.ndarray:
    """The last `n` observations, oldest first, the first repeated before the episode had `n`."""
    frames = history[-n:]
    return np.concatenate([frames[0]] * (n - len(frames)) + frames)


def stacked_inputs(observations: np.ndarray, actions: np.ndarray, history: int, with_actions: bool) -> np.ndarray:
    """The network's input at each of an episode's steps: the last `history` observations
    (oldest first, the first repeated before the episode had them), then, `with_actions`, the
    `history` actions taken before each of them (zero before the first step: nothing was done).
    `observations` holds the steps' observations (T rows), `actions` the T actions taken at them."""
    t = len(observations)
    lags = np.arange(history - 1, -1, -1)
    rows = np.arange(t)[:, None] - lags[None, :]
    parts = [observations[np.clip(rows, 0, None)].reshape(t, -1)]
    if with_actions:
        before = np.concatenate([np.zeros((1, actions.shape[1]), actions.dtype), actions[: t - 1]])  # the action before each step
        shifted = before[np.clip(rows, 0, None)]
        shifted[rows < 0] = 0.0
        parts.append(shifted.reshape(t, -1))
    return np.concatenate(parts, axis=1)


def resolve_clone(spec: str | Path) -> Path:
    """The folder of a saved clone: a path (folder or its bc.pt) or a bundled policy's name."""
    p = Path(spec)
    for folder in (p, p.parent if p.name == WEIGHTS else None, policies_dir() / str(spec)):
        if folder is not None and (folder / SETTINGS).is_file() and (folder / WEIGHTS).is_file():
            return folder
    raise ResourceNotFound(f"no behaviour clone at '{spec}' (a folder with {WEIGHTS} and {SETTINGS}, from opends-gym train bc)")


class BCDriver:
    """Acts with the clone's output for the (normalised) observation; deterministic."""

    def __init__(self, spec: str | Path) -> None:
        torch = require("rl", "torch", "the behaviour-cloned driver")
        self.folder = resolve_clone(spec)
        self.name = f"bc:{spec}"
        path = self.folder / SETTINGS
        try:
            s = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}: line {e.lineno}: not JSON ({e.msg})") from e
        self.settings = s
        self.mean = np.asarray(s["obs_mean"], dtype=np.float32)
        self.std = np.asarray(s["obs_std"], dtype=np.float32)
        self.low = np.asarray(s["action_low"], dtype=np.float32)
        self.high = np.asarray(s["action_high"], dtype=np.float32)
        self.history = int(s.get("history", 1))
        self.with_actions = bool(s.get("actions", False))
        self.obs_size = (len(self.mean) - (self.history * len(self.low) if self.with_actions else 0)) // self.history
        self.squash = "target_std" not in s
        # the observation options of the dataset it was cloned from (data.bc.clone_env_kwargs): the env to drive in
        self.env_kwargs: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in s.get("env_kwargs", {}).items()}
        members = int(s.get("ensemble", 1))  # several: a ModuleList of nets whose outputs are averaged (data.bc)
        nets = [build_mlp(len(self.mean), len(self.low), tuple(s["hidden"]), self.squash) for _ in range(members)]
        self.net = nets[0] if members == 1 else torch.nn.ModuleList(nets)
        self._obs: list[np.ndarray] = []
        self._acts: list[np.ndarray] = []
        self.net.load_state_dict(torch.load(self.folder / WEIGHTS, map_location="cpu", weights_only=True))
        self.net.eval()
        # the forward pass in numpy: one observation through a small MLP takes microseconds,
        # where torch's thread pool on a busy host took ~0.1 s per step
        linear = [[m for m in net if isinstance(m, torch.nn.Linear)] for net in nets]
        self._members = [[(m.weight.detach().numpy().astype(np.float64), m.bias.detach().numpy().astype(np.float64)) for m in ms]
                         for ms in linear]  # fmt: skip

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        config = getattr(env.unwrapped, "config", None)
        for k, v in self.env_kwargs.items():
            if config is not None and getattr(config, k, v) != v:
                raise ValueError(f"clone {self.folder} was trained with {k}={v!r}, the env has {k}={getattr(config, k)!r}")
        shape = env.observation_space.shape
        if shape != (self.obs_size,):
            raise ValueError(f"clone {self.folder} expects observations of shape ({self.obs_size},), the env gives {shape}")
        self._obs, self._acts = [], []

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        """The clone's action (the network's output, deterministic) for this observation and the
        history it keeps, built as `stacked_inputs` built the training inputs."""
        frame = np.asarray(obs, dtype=np.float32)
        self._obs = [*self._obs[-(self.history - 1) :], frame] if self.history > 1 else [frame]
        stacked = stack(self._obs, self.history)
        if self.with_actions:  # the actions before each of the last `history` steps, zero before the first
            taken = self._acts[-self.history :]
            pad = [np.zeros(len(self.low), np.float32)] * (self.history - len(taken))
            stacked = np.concatenate([stacked, *pad, *taken])
        x = np.clip(np.nan_to_num((stacked - self.mean) / self.std, posinf=CLIP, neginf=-CLIP), -CLIP, CLIP)
        outputs = []
        for layers in self._members:
            y = x.astype(np.float64)
            for i, (w, b) in enumerate(layers):
                y = w @ y + b
                if i < len(layers) - 1 or self.squash:  # build_mlp's tanh layers
                    y = np.tanh(y)
            outputs.append(y)
        action = action_output(np.mean(outputs, axis=0), self.settings)
        if self.with_actions:
            self._acts = [*self._acts[-(self.history - 1) :], action] if self.history > 1 else [action]
        return action
