"""Elementwise maths that equals Python's `math` module bit for bit, over numpy arrays.

Why: the single env computes with Python floats and `math`; the native batch must give the
same numbers. +, -, *, /, sqrt, sin, cos, arctan2 and % agree between numpy and Python
(IEEE-754 arithmetic; numpy's sin/cos are correctly rounded here, as is the C library's).
Three do not: numpy's SIMD `tanh`, `arctan` and `tan` differ from the C library's in the
last bit for some inputs, and numpy's `hypot` from CPython's (which has its own, nearly
correctly rounded algorithm). So:

* `tanh`, `arctan`, `tan` call the C library's functions per element through numexpr (the
  same `libm` CPython's `math` calls; numexpr's pip wheels are built without Intel's VML,
  checked at import). Only a bare function call goes through numexpr: its expression
  optimiser would turn a division by a constant into a multiplication.
* `py_hypot` is CPython 3.11's `math.hypot` (`vector_norm` for two values: lossless
  power-of-two scaling, exact squares by Dekker's product, compensated sums and one
  differential correction), written as numpy operations.

`tests/test_vector_native.py` checks all of them against `math` on random inputs.
"""

from __future__ import annotations

import math

import numexpr as ne
import numpy as np

if ne.use_vml:  # pragma: no cover - pip wheels have no VML
    ne.set_vml_accuracy_mode("high")
    raise ImportError("numexpr is built with Intel VML, whose tanh/atan differ from the C library's; install numexpr from PyPI")

_F = np.float64
_TANH = ne.NumExpr("tanh(x)", [("x", _F)])
_ATAN = ne.NumExpr("arctan(x)", [("x", _F)])
_TAN = ne.NumExpr("tan(x)", [("x", _F)])
_SPLIT = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two 26-bit halves


def _libm(fn: ne.NumExpr, x: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    x = np.ascontiguousarray(x, dtype=_F)
    if out is None:
        out = np.empty_like(x)
    if x.size:
        fn(x, out=out, ex_uses_vml=False)
    return out


def tanh(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """`math.tanh` elementwise."""
    return _libm(_TANH, x, out)


def arctan(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """`math.atan` elementwise."""
    return _libm(_ATAN, x, out)


def tan(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """`math.tan` elementwise."""
    return _libm(_TAN, x, out)


def _square_error(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """x*x - p exactly, for p = fl(x*x) (Dekker's product; what CPython's fma() gives)."""
    t = _SPLIT * x
    hi = t - (t - x)
    lo = x - hi
    return ((hi * hi - p) + 2.0 * hi * lo) + lo * lo


def py_hypot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """`math.hypot(x, y)` elementwise (CPython 3.11's vector_norm for two values)."""
    with np.errstate(all="ignore"):
        return _hypot(np.asarray(x, dtype=_F), np.asarray(y, dtype=_F))


def _hypot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    ax, ay = np.abs(x), np.abs(y)
    mx = np.maximum(ax, ay)
    # rare cases (zero, huge, subnormal, non-finite) take the scalar route
    odd = ~((mx > 2.0**-1000) & (mx < 2.0**1000))
    _, e = np.frexp(mx)
    scale = np.ldexp(1.0, -e)
    csum = np.ones_like(mx)
    frac1 = np.zeros_like(mx)
    frac2 = np.zeros_like(mx)
    for v in (ax, ay):
        s = v * scale
        p = s * s
        frac1 += _square_error(s, p)
        hi = csum + p
        frac2 += (csum - hi) + p
        csum = hi
    h = np.sqrt(csum - 1.0 + (frac1 + frac2))
    p = -h * h
    frac1 += -_square_error(h, -p)  # the exact error of (-h)*h is minus that of h*h
    hi = csum + p
    frac2 += (csum - hi) + p
    csum = hi
    h = h + (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)
    out = h / scale
    if odd.any():
        for i in np.flatnonzero(odd):
            out.flat[i] = math.hypot(float(x.flat[i]), float(y.flat[i]))
    return out
