"""`vector.sealed`: a parallel loop's arguments sealed into one value, and workers called
through their address, give what a direct call gives; a worker compiled for other
argument types is refused, not run."""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from opends_gym.vector.sealed import SealedWorker, call_sealed, seal, sealed_tag, unseal


def _scaled_row(i: int, args: Any) -> None:
    """out[i] = a[i] * scale (+ offset where `add`), from nested tuples."""
    a, (scale, add, offset), out = unseal(args)
    out[i] = a[i] * scale + (offset[i] if add else 0.0)


_worker = SealedWorker(_scaled_row)


@njit(parallel=True)
def _rows(address: int, tag: int, a: np.ndarray, params: tuple, out: np.ndarray) -> bool:
    args = seal((a, params, out))
    if tag != sealed_tag(args):
        return False
    for i in prange(len(a)):
        call_sealed(address, i, args)
    return True


def test_worker_through_its_address_matches_the_plain_loop() -> None:
    a, offset = np.linspace(-2.0, 3.0, 37), np.arange(37.0)
    for add in (True, False):
        args = (a, (0.5, add, offset), np.zeros(37))
        assert _rows(*_worker.at(args), *args)
        np.testing.assert_array_equal(args[2], a * 0.5 + (offset if add else 0.0))


def test_worker_compiled_for_other_types_is_refused() -> None:
    a, out = np.arange(5.0), np.full(5, -1.0)
    address, tag = _worker.at((a, (2.0, True, a), out))
    assert not _rows(address, tag, a, (2, True, a), out)  # (an int scale: another tuple type)
    np.testing.assert_array_equal(out, -1.0)  # nothing ran
    assert not _rows(0, -1, a, (2.0, True, a), out)  # (no worker yet: `LctBatch`'s first call)
