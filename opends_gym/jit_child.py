"""The child process in which `opends_gym.jit` has the native batch's kernels compiled: it
reads (module, qualified name, argument types) from its standard input, one pickle each,
compiles that kernel for those types into the machine's numba cache and answers `ok` (or
`error ...`) on a line of its standard output; it ends when its input ends. It also ends as
soon as its parent does (the control pipe, its one argument, closes), unless the parent
wrote `detach` there first: then it compiles what is left in its input, for the cache.
Why a process: see `jit._CompileChild`."""

from __future__ import annotations

import importlib
import os
import pickle
import sys
import threading
from typing import Any, BinaryIO


def _kernel(module: str, qualname: str) -> Any:
    target: Any = importlib.import_module(module)
    for part in qualname.split("."):
        target = getattr(target, part)
    return target


def serve(jobs: BinaryIO, answers: BinaryIO) -> None:
    """Compile each job read from `jobs`; answer each on `answers` (while someone reads them)."""
    while True:
        try:
            module, qualname, signature = pickle.load(jobs)
        except EOFError:
            return
        try:
            _kernel(module, qualname).compile(signature)
            answer = b"ok\n"
        except Exception as e:  # reported to the parent, which compiles the kernel itself
            answer = f"error {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}\n".encode()
        try:
            answers.write(answer)
            answers.flush()
        except OSError:  # the parent has gone (detached): the cache is what counts
            pass


def _watch(control: int) -> None:
    """End this process when the parent ends without detaching it."""
    with os.fdopen(control, "rb") as pipe:
        if pipe.read(6) != b"detach":
            os._exit(0)


def main() -> None:
    os.environ["OPENDS_GYM_JIT_BACKGROUND"] = "0"  # compile here, in the call (no thread of its own)
    threading.Thread(target=_watch, args=(int(sys.argv[1]),), daemon=True).start()
    answers = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # whatever numba prints goes where stderr goes
    serve(sys.stdin.buffer, answers)


if __name__ == "__main__":
    main()
