"""A tuple sealed into one opaque value, for the body of a `prange` loop.

Why: numba's parallel loop passes each free variable of its body to the compiled loop body
as one argument, and a tuple as one argument per item (`parfor_lowering`'s tuple
expansion); the lowering of that body grows faster than linearly with their number. The
LCT's one-region step (`lct_step.lct_step`) handed its body ~90 arrays and scalars: ~94 CPU
s of its cold compile went to that loop alone. Sealed, the whole argument list is one value
of an opaque type, which the loop body hands unopened to a compiled worker that unseals it.

`seal(t)` is a pointer to a copy of `t` in the stack frame of the function that seals it:
use it only within that function and the functions it calls (a `prange` body is such a
call: the function waits for it), and keep the arrays in `t` alive meanwhile (arguments of
the function, or arrays it still uses after the loop): the sealed value holds no reference
to them. `unseal(s)` gives the tuple back.

A parallel loop's body that calls a compiled worker still costs that worker's machine code
again: numba links each callee's code into its caller's module, optimises and emits it
again there, and a parallel loop is two such levels (its body and the function). A
`SealedWorker` is compiled on its own (a numba `cfunc` per tuple type, cached like the
kernels) and called through its address (`call_sealed`), so none of its code is linked into
the loop. `sealed_tag` guards the address: the worker was compiled for the sealed type.
(`lct_score_pass.lct_score_episodes` calls its worker so; `lct_step.lct_step` calls its
worker directly: see docs/performance.md, "The price".)
"""

from __future__ import annotations

import zlib
from typing import Any

import numba
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core import config as numba_config
from numba.extending import intrinsic, models, register_model


class Sealed(types.Type):
    """A pointer to a tuple (its numba type `inner`): not a tuple, so a `prange` body takes
    it as one argument, and the same in a register as in memory (numba's parallel loop
    hands its body each argument through memory)."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        super().__init__(name=f"Sealed({inner})")


register_model(Sealed)(models.OpaqueModel)


@intrinsic
def _seal(typingctx: Any, tup: Any) -> Any:
    """A pointer to a copy of the tuple `tup` in this function's frame (see the module docstring)."""
    if not isinstance(tup, types.BaseTuple):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        slot = cgutils.alloca_once(builder, context.get_value_type(signature.args[0]))  # (in the entry block: one per call site)
        builder.store(args[0], slot)
        return builder.bitcast(slot, cgutils.voidptr_t)

    return Sealed(tup)(tup), codegen


@intrinsic
def _unseal(typingctx: Any, sealed: Any) -> Any:
    """The tuple a `Sealed` pointer points to (a new reference to its arrays, where the caller counts them)."""
    if not isinstance(sealed, Sealed):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        slot = builder.bitcast(args[0], context.get_value_type(signature.return_type).as_pointer())
        inner = builder.load(slot)
        if context.enable_nrt:
            context.nrt.incref(builder, signature.return_type, inner)
        return inner

    return sealed.inner(sealed), codegen


def _tag(inner: Any) -> int:
    """A number naming a sealed tuple's numba type (the same in every process)."""
    return zlib.crc32(str(inner).encode())


@intrinsic
def _sealed_tag(typingctx: Any, sealed: Any) -> Any:
    """`_tag` of the sealed value's tuple type, a constant (compare with `SealedWorker.at`'s)."""
    if not isinstance(sealed, Sealed):
        return None
    tag = _tag(sealed.inner)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return context.get_constant(types.int64, tag)

    return types.int64(sealed), codegen


@intrinsic
def _call_sealed(typingctx: Any, address: Any, i: Any, sealed: Any) -> Any:
    """Call the `SealedWorker` at `address` (`at`) with (i, sealed)."""
    if not (isinstance(address, types.Integer) and isinstance(i, types.Integer) and isinstance(sealed, Sealed)):
        return None

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fnty = ir.FunctionType(ir.VoidType(), [ir.IntType(64), cgutils.voidptr_t])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(fn, [context.cast(builder, args[1], signature.args[1], types.int64), args[2]])
        return context.get_dummy_value()

    return types.none(address, i, sealed), codegen


class SealedWorker:
    """`fn(i, sealed)` compiled per sealed tuple type (a cached numba `cfunc`, void(int64,
    Sealed)), for `call_sealed` (see the module docstring). `fn` unseals its argument."""

    def __init__(self, fn: Any, **options: Any) -> None:
        self.fn, self.options = fn, options
        self._compiled: dict[str, Any] = {}

    def at(self, args: tuple) -> tuple[int, int]:  # type: ignore[type-arg]
        """The worker for the tuple `args` (as the caller seals it): (address, `_tag`)."""
        if _CONFIG.DISABLE_JIT:  # (plain Python: `call_sealed` calls `fn` itself)
            _PLAIN[id(self.fn)] = self.fn
            return id(self.fn), 0
        inner = numba.typeof(args)
        key = str(inner)
        worker = self._compiled.get(key)
        if worker is None:
            worker = numba.cfunc(types.void(types.int64, Sealed(inner)), cache=True, **self.options)(self.fn)
            self._compiled[key] = worker  # (keeps its code alive)
        return int(worker.address or 0), _tag(inner)


def _as_is(value: Any) -> Any:
    """`seal` and `unseal` in plain Python (NUMBA_DISABLE_JIT): nothing to seal."""
    return value


_CONFIG: Any = numba_config
seal: Any = _as_is if _CONFIG.DISABLE_JIT else _seal
unseal: Any = _as_is if _CONFIG.DISABLE_JIT else _unseal
_PLAIN: dict[int, Any] = {}  # (NUMBA_DISABLE_JIT: `SealedWorker.at`'s functions by their "address")


def _plain_call(address: int, i: int, sealed: Any) -> None:
    """`call_sealed` in plain Python."""
    _PLAIN[address](i, sealed)


sealed_tag: Any = (lambda sealed: 0) if _CONFIG.DISABLE_JIT else _sealed_tag
call_sealed: Any = _plain_call if _CONFIG.DISABLE_JIT else _call_sealed
