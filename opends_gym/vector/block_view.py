"""A trace ring's block as an array from its address, and a hint to fetch a block's line for writing.

Why: the compiled passes that read ended episodes straight from a `trace.TraceRing`
(`trace.read_rows`, used by the LCT's and the platoon's scoring passes) take the ring's
blocks as an int64 array of addresses (`TraceRing.block_addresses`): a list of arrays as a
kernel argument costs numba's typed list, compiled afresh in every process (~0.5 s). And
the brake and platoon pass writes each env's trace rows into memory it has not touched for
a while: fetching the next env's rows ahead (`prefetch_write`) hides those cache misses.
Both are plain Python functions with compiled overloads, so kernels running as Python
(`opends_gym.jit`) call them too.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload


def block_at(address: int, shape: tuple[int, int, int, int]) -> np.ndarray:
    """The float64 array of `shape` at `address` (a `TraceRing` block, held by the ring: a
    list of arrays as an argument would cost numba's typed list, compiled afresh in every
    process, ~0.5 s). As Python (a kernel running as Python while it compiles,
    `opends_gym.jit`): the same view through ctypes."""
    return np.ctypeslib.as_array(ctypes.cast(int(address), ctypes.POINTER(ctypes.c_double)), shape)


@intrinsic
def _f64_pointer(typingctx: Any, address: Any) -> Any:
    """An int64 address as a float64 pointer (for `numba.carray`)."""
    if not isinstance(address, types.Integer):
        return None
    pointer = types.CPointer(types.float64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], context.get_value_type(pointer))

    return pointer(address), codegen


@overload(block_at, inline="always")
def _block_at_compiled(address: Any, shape: Any) -> Any:
    """`block_at` in compiled kernels: a pointer cast."""

    def view(address: Any, shape: Any) -> Any:  # (the same parameters as the typing function: numba compares them)
        return numba.carray(_f64_pointer(address), shape)  # type: ignore[call-arg]  # (typingctx: numba passes it)

    return view


def prefetch_write(array: np.ndarray, at: tuple[int, int, int, int]) -> None:
    """Ask the CPU to fetch the cache line of array[at] for writing (LLVM's prefetch,
    `_prefetch_compiled`). As Python: nothing (a hint)."""


@intrinsic
def _prefetch_line(typingctx: Any, array: Any, at: Any) -> Any:
    """`llvm.prefetch` (write, keep in all cache levels) of the element `at` of an array."""
    if not (isinstance(array, types.Array) and isinstance(at, types.UniTuple) and len(at) == array.ndim):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        array_type, index_type = signature.args
        view = context.make_array(array_type)(context, builder, args[0])
        indices = cgutils.unpack_tuple(builder, args[1], count=len(index_type))
        pointer = cgutils.get_item_pointer(context, builder, array_type, view, indices, wraparound=False)
        i32 = ir.IntType(32)
        function_type = ir.FunctionType(ir.VoidType(), [pointer.type, i32, i32, i32])
        function = cgutils.get_or_insert_function(builder.module, function_type, "llvm.prefetch.p0")
        builder.call(function, [pointer, ir.Constant(i32, 1), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return types.none(array, at), codegen


# (no `inline="always"`: numba's inlining of this into a kernel that also inlines `platoon_step.after_one`
# mixed up their local names, and the brake test's trace lost its lon_dev column; LLVM inlines the call anyway)
@overload(prefetch_write)
def _prefetch_compiled(array: Any, at: Any) -> Any:
    """`prefetch_write` in compiled kernels."""

    def hint(array: Any, at: Any) -> None:
        _prefetch_line(array, at)  # type: ignore[call-arg]  # (typingctx: numba passes it)

    return hint
