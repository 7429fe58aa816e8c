"""numpy's reductions in compiled code, with numpy's floats.

Why: compiled episode scoring (`platoon_scores`) must give the same floats as
the numpy code it replaces (the native batch's metrics are tested equal to the single
env's, and users compare runs). A plain loop adds in another order than `np.sum`, which
sums blocks of 8 lanes pairwise; `np_sum` repeats numpy's order.
"""

from __future__ import annotations

import numpy as np

from ..jit import kernel

_BLOCK = 128  # numpy's PW_BLOCKSIZE


@kernel
def _block(a: np.ndarray, lo: int, n: int) -> float:
    """numpy's `pairwise_sum` of a[lo:lo+n] for n <= 128 (numpy/_core/src/umath/loops_utils.h.src):
    a plain loop below 8 values, else 8 running sums added pairwise, then the rest."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
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


@kernel
def _pairwise(a: np.ndarray, lo: int, n: int) -> float:
    """numpy's `pairwise_sum`: above 128 values, the sum of its two halves (the first a multiple
    of 8 long), each summed the same way. numpy recurses; this walks the same tree with a stack
    (numba's cache loads recursive functions broken: numba issue 6061)."""
    if n <= _BLOCK:
        return _block(a, lo, n)
    depth = 2 * 64 + 2  # (each level splits n at least in half)
    los, ns = np.empty(depth, dtype=np.int64), np.empty(depth, dtype=np.int64)
    done = np.zeros(depth, dtype=np.bool_)  # the frame's halves are summed: add them
    sums = np.empty(depth)
    top, sp = 0, 0
    los[0], ns[0], done[0] = lo, n, False
    while top >= 0:
        flo, fn, fdone = los[top], ns[top], done[top]
        top -= 1
        if fn <= _BLOCK:
            sums[sp] = _block(a, flo, fn)
            sp += 1
        elif fdone:
            sums[sp - 2] = sums[sp - 2] + sums[sp - 1]
            sp -= 1
        else:
            n2 = fn // 2
            n2 -= n2 % 8
            los[top + 1], ns[top + 1], done[top + 1] = flo, fn, True
            los[top + 2], ns[top + 2], done[top + 2] = flo + n2, fn - n2, False
            los[top + 3], ns[top + 3], done[top + 3] = flo, n2, False
            top += 3
    return sums[0]


@kernel
def np_sum(a: np.ndarray, lo: int, n: int) -> float:
    """`float(np.sum(a[lo:lo+n]))` for a float64 array: numpy's add.reduce starts from its
    identity 0.0 and adds the pairwise sum of all n values (so an empty sum is 0.0)."""
    return 0.0 + _pairwise(a, lo, n)
