"""Batched action types: `continuous` and `continuous_buttons` for N envs at once.

Why: `envs.actions.ContinuousAction` / `ContinuousButtonsAction` turn one action into
`DriverControls`; here a (N, k) array becomes arrays of steering, gas and brake plus the
button edges, with the same checks (NaN or infinity is an error naming the env) and the
same clipping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..envs.actions import BUTTONS

SIGNAL_OFF, SIGNAL_LEFT, SIGNAL_RIGHT = 0, 1, 2


@dataclass
class BatchControls:
    steer: np.ndarray
    gas: np.ndarray
    brake: np.ndarray
    pressed: np.ndarray  # reaction button/key pressed this policy step (an edge; first substep only)
    signal: np.ndarray  # the driver's indicator: 0 off, 1 left, 2 right


class BatchActions:
    """Action conversion of one action type for N envs."""

    def __init__(self, name: str, n: int) -> None:
        if name not in ("continuous", "continuous_buttons"):
            raise ValueError(f"the native batch supports the continuous and continuous_buttons action types, not {name!r}")
        self.name = name
        self.width = 2 if name == "continuous" else 2 + len(BUTTONS)
        self.held = np.zeros((n, len(BUTTONS)), dtype=bool)

    def reset_rows(self, idx: np.ndarray) -> None:
        self.held[idx] = False

    def convert(self, actions: np.ndarray, rows: np.ndarray) -> BatchControls:
        """Controls for every env; `rows` are the envs that step (the others reset)."""
        a = np.asarray(actions, dtype=np.float64)
        n = len(self.held)
        if a.shape != (n, self.width):
            raise ValueError(f"actions must have shape ({n}, {self.width}), got {a.shape}")
        finite = np.isfinite(a).all(axis=1) | ~rows
        if not finite.all():
            e = int(np.flatnonzero(~finite)[0])
            raise ValueError(f"env {e}: action contains NaN or infinity: {a[e].tolist()}")
        a = np.clip(a, -1.0, 1.0)
        pedal = a[:, 1]
        steer = a[:, 0].copy()
        gas = np.maximum(pedal, 0.0)
        brake = np.maximum(-pedal, 0.0)
        pressed = np.zeros(n, dtype=bool)
        signal = np.zeros(n, dtype=np.int64)
        if self.name == "continuous_buttons":
            down = a[:, 2:] > 0.0
            edge = down & ~self.held
            self.held = np.where(rows[:, None], down, self.held)
            pressed = edge[:, 0] & rows
            left, right = down[:, 2], down[:, 3]
            signal = np.where(left & ~right, SIGNAL_LEFT, np.where(right & ~left, SIGNAL_RIGHT, SIGNAL_OFF))
        return BatchControls(steer, gas, brake, pressed, signal)
