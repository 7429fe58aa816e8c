"""numba's `njit` with this project's settings, and maths that equals CPython's bit for bit.

Why: the per-step maths of the ego car, traffic and the native batch runs as compiled
kernels (issue 9). The settings matter for results, so they live here, once:

* never `fastmath`: it allows FMA contraction and reassociation, which change the last bits
  and make results depend on the machine; without it LLVM keeps IEEE-754 semantics, so a
  kernel computes exactly what the same Python expression computes;
* `cache=True`: compiled machine code is kept next to the module (or in numba's user cache
  when that folder is read-only), so only the first process on a machine compiles; later
  processes (SubprocVecEnv workers included) load it. The cache key includes a hash of all
  kernel modules (`_kernel_sources_stamp`), since a kernel inlines kernels of other files;
* `nogil=True`: the native batch steps shards in threads.

`parallel_kernel` adds numba's `parallel=True` for the native batch's whole-batch steps:
their `prange` loops run chunks of envs on numba's thread pool (`NUMBA_NUM_THREADS`, by
default one thread per core). Each chunk is a call to a plain `kernel` (numba's parfor
lowering of a long loop body compiled slower code here than the same body as a function).
Unless the user chose a threading layer (`NUMBA_THREADING_LAYER`), importing this module
picks numba's `workqueue` layer: GNU OpenMP's threads spin while they wait, and on a host
whose cores are busy with other programs a 4,096-env LCT step took 120-170 ms with it
instead of 20 ms (2 threads, 2 cores, load 11), and a process forked after it started
cannot use it. The workqueue layer must not be entered from two Python threads at once:
batches stepped in threads call their kernels' serial twins (`vector.env`).

numba's `math.sin/cos/tan/atan/atan2/tanh/sqrt` call the same C library functions as
CPython's `math` (checked in the tests), and `%` on floats has Python's semantics. Only
`math.hypot` differs (CPython has its own algorithm), hence `py_hypot`.

`NUMBA_DISABLE_JIT=1` runs every kernel as plain Python (for debugging), with the same
results: kernels use only what Python and numba agree on.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar, cast

import numba
from numba import njit

F = TypeVar("F", bound=Callable[..., Any])

_SPLIT = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two 26-bit halves
_DBL_MIN = 2.2250738585072014e-308


_PACKAGE = Path(__file__).resolve().parent
_KERNEL_SOURCES = ("sim", "vector", "metrics")  # the folders whose modules define kernels


@functools.cache
def _kernel_sources_stamp() -> str:
    """A hash of every module that defines kernels. numba checks only the file of a cached
    function, not those of the kernels it calls (and inlines); with this stamp in every cache
    key, an edit to any kernel module recompiles them all instead of running stale code."""
    digest = hashlib.sha256()
    for folder in _KERNEL_SOURCES:
        for path in sorted((_PACKAGE / folder).rglob("*.py")):
            digest.update(str(path.relative_to(_PACKAGE)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _register_cache_stamp() -> None:
    """Put `_kernel_sources_stamp` into the cache keys of this package's kernels (through
    numba's cache locators; left to numba's own stamps if its internals differ)."""
    try:
        from numba.core import caching

        bases = (caching.UserProvidedCacheLocator, caching.InTreeCacheLocator, caching.UserWideCacheLocator)
        classes = caching.CacheImpl._locator_classes
    except AttributeError:  # pragma: no cover - another numba
        return
    if any(getattr(c, "_opends_gym", False) for c in classes):
        return

    def stamped(base: Any) -> Any:
        class Locator(base):  # type: ignore[misc, valid-type]
            _opends_gym = True

            @classmethod
            def from_function(cls, py_func: Any, py_file: str) -> Any:
                if not Path(py_file).resolve().is_relative_to(_PACKAGE):
                    return None
                return super().from_function(py_func, py_file)

            def get_source_stamp(self) -> Any:
                return (super().get_source_stamp(), _kernel_sources_stamp())

        return Locator

    classes[:0] = [stamped(b) for b in bases]


_register_cache_stamp()


def _choose_threading_layer() -> None:
    """`workqueue` unless the user chose a layer (see the module docstring)."""
    config: Any = numba.config
    if not os.environ.get("NUMBA_THREADING_LAYER") and config.THREADING_LAYER == "default":
        config.THREADING_LAYER = "workqueue"


_choose_threading_layer()


def kernel(fn: F) -> F:
    """Compile `fn` with the project's numba settings (see the module docstring)."""
    return cast(F, njit(cache=True, nogil=True)(fn))


def parallel_kernel(fn: F) -> F:
    """A `kernel` whose `prange` loops run in parallel (see the module docstring)."""
    return cast(F, njit(cache=True, nogil=True, parallel=True)(fn))


def inline(fn: F) -> F:
    """A `kernel` that is inlined into the kernels calling it: a call between compiled
    functions passes every array as a struct of seven words and updates its reference count,
    which costs more than the small helpers themselves. Call it only from kernels (numba
    would compile it afresh in every process that calls it from Python)."""
    return cast(F, njit(cache=True, nogil=True, inline="always")(fn))


@kernel
def _square_error(x: float, p: float) -> float:
    """x*x - p exactly, for p = fl(x*x) (Dekker's product; what CPython's fma() gives)."""
    t = _SPLIT * x
    hi = t - (t - x)
    lo = x - hi
    return ((hi * hi - p) + 2.0 * hi * lo) + lo * lo


@kernel
def _norm2(ax: float, ay: float, mx: float) -> float:
    """CPython 3.11's `vector_norm` for two finite, non-negative values of maximum mx > 0."""
    _, e = math.frexp(mx)
    scale = math.ldexp(1.0, -e)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    s = ax * scale  # lossless scaling
    p = s * s
    frac1 += _square_error(s, p)
    hi = csum + p
    frac2 += (csum - hi) + p
    csum = hi
    s = ay * scale
    p = s * s
    frac1 += _square_error(s, p)
    hi = csum + p
    frac2 += (csum - hi) + p
    csum = hi
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    p = -h * h
    frac1 += -_square_error(h, -p)  # the exact error of (-h)*h is minus that of h*h
    hi = csum + p
    frac2 += (csum - hi) + p
    csum = hi
    h = h + (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)  # differential correction
    return h / scale


@kernel
def py_hypot(x: float, y: float) -> float:
    """`math.hypot(x, y)` exactly as CPython 3.11 computes it."""
    ax, ay = abs(x), abs(y)
    mx = ax if ax > ay else ay
    if math.isinf(ax) or math.isinf(ay):
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    if mx == 0.0:
        return 0.0
    if math.frexp(mx)[1] < -1023:  # tiny: CPython scales by DBL_MIN first
        return _DBL_MIN * _norm2(ax / _DBL_MIN, ay / _DBL_MIN, mx / _DBL_MIN)
    return _norm2(ax, ay, mx)
