"""A behaviour-cloned driver: a small torch MLP from observation to action (`--agent bc:NAME`).

Why here: every agent spec resolves in `drivers.agents`, so a clone drives `run`, studies and
benchmarks like any other driver. The network and its file format live beside the driver;
`opends_gym.data.bc` trains it. A saved clone is a folder with `bc.pt` (the weights) and
`bc.json` (sizes, observation normalisation, action bounds, the env and dataset it came from,
`history`: how many recent observations the network sees, oldest first, so it can learn a
driver's delays; a memoryless clone acts the moment it sees a sign).
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


def build_mlp(obs_dim: int, act_dim: int, hidden: tuple[int, ...]) -> Any:
    """tanh MLP whose output, in [-1, 1], is scaled onto the action bounds by the driver."""
    torch = require("rl", "torch", "the behaviour-cloned driver")
    layers: list[Any] = []
    last = obs_dim
    for h in hidden:
        layers += [torch.nn.Linear(last, h), torch.nn.Tanh()]
        last = h
    layers += [torch.nn.Linear(last, act_dim), torch.nn.Tanh()]
    return torch.nn.Sequential(*layers)


def stack(history: list[np.ndarray], n: int) -> np.ndarray:
    """The last `n` observations, oldest first, the first repeated before the episode had `n`."""
    frames = history[-n:]
    return np.concatenate([frames[0]] * (n - len(frames)) + frames)


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
        self.net = build_mlp(len(self.mean), len(self.low), tuple(s["hidden"]))
        self._frames: list[np.ndarray] = []
        self.net.load_state_dict(torch.load(self.folder / WEIGHTS, map_location="cpu", weights_only=True))
        self.net.eval()
        self._torch = torch

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        shape = env.observation_space.shape
        size = len(self.mean) // self.history
        if shape != (size,):
            raise ValueError(f"clone {self.folder} expects observations of shape ({size},), the env gives {shape}")
        self._frames = []

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        self._frames = [*self._frames[-(self.history - 1) :], np.asarray(obs, dtype=np.float32)] if self.history > 1 else [obs]
        stacked = stack(self._frames, self.history) if self.history > 1 else np.asarray(obs, dtype=np.float32)
        x = np.clip(np.nan_to_num((stacked - self.mean) / self.std, posinf=CLIP, neginf=-CLIP), -CLIP, CLIP)
        with self._torch.no_grad():
            y = self.net(self._torch.from_numpy(x.astype(np.float32))).numpy()
        return (self.low + (y + 1.0) * 0.5 * (self.high - self.low)).astype(np.float32)
