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

A parallel loop's body that calls a compiled worker still links that worker's machine code
into the loop (numba optimises and emits each callee again in its caller's module). Calling
the worker through the address of a separately compiled `cfunc` avoided that, but such a
`cfunc` compiles in the Python call that asks for its address, which would freeze a batch
running as Python on a cold cache (`opends_gym.jit`); it was left out (docs/performance.md,
"The price"). The sealed loops of `lct_step` call their workers directly.
"""

from __future__ import annotations

from typing import Any

from numba import types
from numba.core import cgutils
from numba.core import config as numba_config
from numba.extending import intrinsic, models, register_model

from ..jit import python_stand_in


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


def _as_is(value: Any) -> Any:
    """`seal` and `unseal` as Python: nothing to seal."""
    return value


_CONFIG: Any = numba_config
seal: Any = _as_is if _CONFIG.DISABLE_JIT else _seal
unseal: Any = _as_is if _CONFIG.DISABLE_JIT else _unseal
python_stand_in(_seal, _as_is)
python_stand_in(_unseal, _as_is)
