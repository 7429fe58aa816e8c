"""Batched action types: `continuous` and `continuous_buttons` for N envs at once.

Why: `envs.actions.ContinuousAction` / `ContinuousButtonsAction` turn one action into
`DriverControls`; here a (N, k) array becomes arrays of steering, gas and brake plus the
button edges, with the same checks (NaN or infinity is an error naming the env) and the
same clipping. The check and the `continuous` conversion are one compiled pass
(`first_nonfinite`, `continuous_controls`): a policy step's serial Python per env.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..envs.actions import BUTTONS
from ..jit import inline, kernel

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

    def convert(self, actions: np.ndarray, rows: np.ndarray, checked: bool = False) -> BatchControls:
        """Controls for every env; `rows` are the envs that step (the others reset). `checked`:
        the caller refused NaN and infinity in `rows` already (`NativeVectorEnv.step` does)."""
        a = np.asarray(actions, dtype=np.float64)
        n = len(self.held)
        if a.shape != (n, self.width):
            raise ValueError(f"actions must have shape ({n}, {self.width}), got {a.shape}")
        bad = -1 if checked else first_nonfinite(a, rows)
        if bad >= 0:
            raise ValueError(f"env {bad}: action contains NaN or infinity: {a[bad].tolist()}")
        steer, gas, brake = np.empty(n), np.empty(n), np.empty(n)
        continuous_controls(a, steer, gas, brake)
        pressed = np.zeros(n, dtype=bool)
        signal = np.zeros(n, dtype=np.int64)
        if self.name == "continuous_buttons":
            down = a[:, 2:] > 0.0  # (as after np.clip: NaN is not > 0 either)
            edge = down & ~self.held
            self.held = np.where(rows[:, None], down, self.held)
            pressed = edge[:, 0] & rows
            left, right = down[:, 2], down[:, 3]
            signal = np.where(left & ~right, SIGNAL_LEFT, np.where(right & ~left, SIGNAL_RIGHT, SIGNAL_OFF))
        return BatchControls(steer, gas, brake, pressed, signal)


def action_block(actions: np.ndarray, n: int, width: int) -> np.ndarray:
    """The (n, width) actions as a C-ordered float array for a compiled pass: float32 and
    float64 as given (each float32 widens to the float64 `np.asarray` would give), others
    converted to float64."""
    a = np.asarray(actions)
    if a.dtype not in (np.float32, np.float64):
        try:
            a = a.astype(np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"actions must be numbers, got dtype {a.dtype}") from None
    if a.shape != (n, width):
        raise ValueError(f"actions must have shape ({n}, {width}), got {a.shape}")
    return a if a.flags.c_contiguous else np.ascontiguousarray(a)


@kernel
def first_nonfinite(a: np.ndarray, rows: np.ndarray) -> int:
    """The first env of `rows` whose action row of `a` holds NaN or infinity (-1: none)."""
    return nonfinite_in(a, rows, 0, a.shape[0])


@inline
def nonfinite_in(a: np.ndarray, rows: np.ndarray, lo: int, hi: int) -> int:
    """`first_nonfinite` among the envs lo..hi-1 (a chunk of a parallel pass)."""
    for e in range(lo, hi):
        if rows[e]:
            for j in range(a.shape[1]):
                if not math.isfinite(a[e, j]):
                    return e
    return -1


@kernel
def continuous_controls(a: np.ndarray, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:
    """Steering, gas and brake of every env from the first two action columns, the floats of
    `np.clip(a, -1, 1)`, `np.maximum(pedal, 0)`, `np.maximum(-pedal, 0)` (NaN stays NaN, a
    zero pedal gives +0.0: numpy's maximum returns its second operand when they are equal)."""
    for e in range(a.shape[0]):
        continuous_row(a, e, steer, gas, brake)


@inline
def continuous_row(a: np.ndarray, e: int, steer: np.ndarray, gas: np.ndarray, brake: np.ndarray) -> None:
    """`continuous_controls` of env e alone (a chunk of a parallel pass calls it env by env)."""
    s, p = a[e, 0], a[e, 1]
    steer[e] = -1.0 if s < -1.0 else 1.0 if s > 1.0 else s
    p = -1.0 if p < -1.0 else 1.0 if p > 1.0 else p
    gas[e] = p if p > 0.0 or p != p else 0.0
    brake[e] = -p if -p > 0.0 or p != p else 0.0
