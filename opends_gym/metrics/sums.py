"""numpy's reductions in compiled code, with numpy's floats.

Why: compiled episode scoring (`platoon_scores`, `headway`) must give the same floats as
the numpy code it replaces (the native batch's metrics are tested equal to the single
env's, and users compare runs). A plain loop adds in another order than `np.sum`, which
sums blocks of 8 lanes pairwise; `np_sum` repeats numpy's order.
"""

from __future__ import annotations

import numpy as np

from ..jit import kernel

_BLOCK = 128  # numpy's PW_BLOCKSIZE


@kernel
def _pairwise(a: np.ndarray, lo: int, n: int) -> float:
    """numpy's `pairwise_sum` of a[lo:lo+n] (numpy/_core/src/umath/loops_utils.h.src)."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    if n <= _BLOCK:
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        i = 8
        while i < n - (n % 8):
            j = lo + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[lo + i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise(a, lo, n2) + _pairwise(a, lo + n2, n - n2)


@kernel
def np_sum(a: np.ndarray, lo: int, n: int) -> float:
    """`float(np.sum(a[lo:lo+n]))` for a float64 array: numpy's add.reduce starts from its
    identity 0.0 and adds the pairwise sum of all n values (so an empty sum is 0.0)."""
    return 0.0 + _pairwise(a, lo, n)
