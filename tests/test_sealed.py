"""`vector.sealed`: a parallel loop whose body takes its arguments sealed into one value
(nested tuples, arrays written through) gives what the plain loop gives. (As Python, through
`jit.python_stand_in`: tests/test_native_cold.py runs the LCT batch's sealed loops so.)"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from opends_gym.vector.sealed import seal, unseal


def _scaled_row(i: int, args: Any) -> None:
    """out[i] = a[i] * scale (+ offset where `add`), from nested tuples."""
    a, (scale, add, offset), out = unseal(args)
    out[i] = a[i] * scale + (offset[i] if add else 0.0)


_scaled_row_compiled = njit(_scaled_row)


@njit(parallel=True)
def _rows(a: np.ndarray, params: tuple, out: np.ndarray) -> None:  # type: ignore[type-arg]
    args = seal((a, params, out))
    for i in prange(len(a)):
        _scaled_row_compiled(i, args)


def test_sealed_arguments_give_the_plain_loops_results() -> None:
    a, offset = np.linspace(-2.0, 3.0, 37), np.arange(37.0)
    for add in (True, False):
        want = a * 0.5 + (offset if add else 0.0)
        out = np.zeros(37)
        _rows(a, (0.5, add, offset), out)
        np.testing.assert_array_equal(out, want)
