"""The brake and platoon test batches' action check and controls as one compiled call.

Why: `BatchActions.convert` checks the actions, converts them (`continuous_controls`) and
finds the button edges and the indicator with a dozen numpy expressions over the batch
(each a Python call and a temporary), after `NativeVectorEnv.step` checked them once more.
Here one pass does the check and the buttons, with `convert`'s rules, into arrays the batch
keeps (`PlatoonBatch.checks_actions`: the env leaves the check to it).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from ..envs.actions import BUTTONS
from ..jit import inline, kernel, parallel_kernel
from .actions import SIGNAL_LEFT, SIGNAL_OFF, SIGNAL_RIGHT, continuous_row, nonfinite_in
from .kernels import chunk_count

# From how many envs the parallel pass pays: its threads wake from the Python before it, which
# on a 2-core host cost what a second thread saved up to 8,192 envs (~23 ns per env-step on
# one and on two threads, `benchmarks/serial_share.py`), while at 32,768 envs on 16 threads the
# serial pass was 1.5 ms, ~7 % of the platoon step (docs/performance.md, 16 cores, round 13).
PARALLEL_CONTROLS_ENVS = 16384


@kernel
def step_controls(a: np.ndarray, stepping: np.ndarray, buttons: bool, held: np.ndarray, steer: np.ndarray, gas: np.ndarray,
                  brake: np.ndarray, pressed: np.ndarray, signal: np.ndarray) -> int:  # fmt: skip
    """`BatchActions.convert(a, stepping)` into the arrays given (`buttons`: the
    `continuous_buttons` action type, whose button columns follow steering and pedal):
    returns the first stepping env whose action holds NaN or infinity (-1: none; then
    nothing was written). A button is down above 0; the reaction button is pressed on its
    edge (down, not held before) in a stepping env; the buttons held are those of the
    stepping envs' actions; the indicator is left or right when only that button is down."""
    n = a.shape[0]
    bad = nonfinite_in(a, stepping, 0, n)
    if bad < 0:
        _controls_range(0, n, a, stepping, buttons, held, steer, gas, brake, pressed, signal)
    return bad


@parallel_kernel
def step_controls_parallel(a: np.ndarray, stepping: np.ndarray, buttons: bool, held: np.ndarray, steer: np.ndarray, gas: np.ndarray,
                           brake: np.ndarray, pressed: np.ndarray, signal: np.ndarray) -> int:  # fmt: skip
    """`step_controls` with chunks of envs on numba's threads, the same answer and arrays, for
    batches of `PARALLEL_CONTROLS_ENVS` envs or more. Why: run serially its pass was ~7 % of a
    16-thread platoon batch's step (32,768 envs, `benchmarks/serial_share.py` on a 16-core
    host), a share that grows with the threads."""
    n = a.shape[0]
    chunks = chunk_count(n)
    first = np.full(chunks, -1, dtype=np.int64)
    for j in prange(chunks):
        first[j] = nonfinite_in(a, stepping, j * n // chunks, (j + 1) * n // chunks)
    for j in range(chunks):  # (chunks in env order: the first chunk with one holds the first env)
        if first[j] >= 0:
            return first[j]
    for j in prange(chunks):
        _controls_range(j * n // chunks, (j + 1) * n // chunks, a, stepping, buttons, held, steer, gas, brake, pressed, signal)
    return -1


def compile_parallel_controls() -> None:
    """Call `step_controls_parallel` once, on two envs, with the types the batches pass: for
    `opends-gym compile`, whose batches are smaller than `PARALLEL_CONTROLS_ENVS`, so that a
    large batch finds it in the cache instead of running it as Python while it compiles."""
    n = 2
    step_controls_parallel(np.zeros((n, 2 + len(BUTTONS))), np.ones(n, dtype=bool), True, np.zeros((n, len(BUTTONS)), dtype=bool),
                           np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64))  # fmt: skip


@inline
def _controls_range(lo: int, hi: int, a: np.ndarray, stepping: np.ndarray, buttons: bool, held: np.ndarray, steer: np.ndarray,
                    gas: np.ndarray, brake: np.ndarray, pressed: np.ndarray, signal: np.ndarray) -> None:  # fmt: skip
    """The controls of the envs lo..hi-1 (`step_controls`' rules)."""
    for e in range(lo, hi):
        continuous_row(a, e, steer, gas, brake)
        pressed[e], signal[e] = False, SIGNAL_OFF
        if buttons:
            left, right = a[e, 4] > 0.0, a[e, 5] > 0.0
            signal[e] = SIGNAL_LEFT if left and not right else SIGNAL_RIGHT if right and not left else SIGNAL_OFF
            if stepping[e]:
                pressed[e] = a[e, 2] > 0.0 and not held[e, 0]
                for j in range(held.shape[1]):
                    held[e, j] = a[e, 2 + j] > 0.0
