"""The brake and platoon test batches' action check and controls as one compiled call.

Why: `BatchActions.convert` checks the actions, converts them (`continuous_controls`) and
finds the button edges and the indicator with a dozen numpy expressions over the batch
(each a Python call and a temporary), after `NativeVectorEnv.step` checked them once more.
Here one pass does the check and the buttons, with `convert`'s rules, into arrays the batch
keeps (`PlatoonBatch.checks_actions`: the env leaves the check to it).
"""

from __future__ import annotations

import numpy as np

from ..jit import kernel
from .actions import SIGNAL_LEFT, SIGNAL_OFF, SIGNAL_RIGHT, continuous_controls, first_nonfinite


@kernel
def step_controls(a: np.ndarray, stepping: np.ndarray, buttons: bool, held: np.ndarray, steer: np.ndarray, gas: np.ndarray,
                  brake: np.ndarray, pressed: np.ndarray, signal: np.ndarray) -> int:  # fmt: skip
    """`BatchActions.convert(a, stepping)` into the arrays given (`buttons`: the
    `continuous_buttons` action type, whose button columns follow steering and pedal):
    returns the first stepping env whose action holds NaN or infinity (-1: none; then
    nothing was written). A button is down above 0; the reaction button is pressed on its
    edge (down, not held before) in a stepping env; the buttons held are those of the
    stepping envs' actions; the indicator is left or right when only that button is down."""
    bad = first_nonfinite(a, stepping)
    if bad >= 0:
        return bad
    continuous_controls(a, steer, gas, brake)
    for e in range(a.shape[0]):
        pressed[e], signal[e] = False, SIGNAL_OFF
        if buttons:
            left, right = a[e, 4] > 0.0, a[e, 5] > 0.0
            signal[e] = SIGNAL_LEFT if left and not right else SIGNAL_RIGHT if right and not left else SIGNAL_OFF
            if stepping[e]:
                pressed[e] = a[e, 2] > 0.0 and not held[e, 0]
                for j in range(held.shape[1]):
                    held[e, j] = a[e, 2 + j] > 0.0
    return -1
