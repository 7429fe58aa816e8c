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
* `nogil=True`: the native batch steps shards in threads;
* compiled in the background (`OPENDS_GYM_JIT_BACKGROUND`, default on): a kernel called
  from Python for argument types it has no machine code for yet runs as plain Python (its
  `py_func`, with the same results, see below) while a child process compiles it into the
  cache (`_CompileChild`: the compile does not share this process's interpreter lock with
  the steps) and one background thread loads it and swaps it in. So the first step after a
  fresh install, or the first step of a new process while numba loads its typing registries
  (0.3-0.6 s), does not freeze for the compile (4-18 s for a single env on an idle host,
  minutes for a native batch; `benchmarks/cold_start.py`, `benchmarks/cold_native.py`); see
  `_Background`. At exit the child is left to finish the queued compiles, so the cache
  fills once per machine. `opends-gym compile` fills it ahead (`compile_in_call`). Two
  exceptions keep a native batch's Python steps rare and cheap: a whole-batch kernel
  (a `parallel_kernel`, or a serial one marked `whole_batch`) whose code the cache already
  holds loads in its first call (`_in_cache`), and the hot passes marked `python_buffers`
  run as Python on memoryviews.

`parallel_kernel` adds numba's `parallel=True` for the native batch's whole-batch steps:
their `prange` loops run chunks of envs on numba's thread pool (`NUMBA_NUM_THREADS`, by
default one thread per core). Each chunk is a call to a plain `kernel` (numba's parfor
lowering of a long loop body compiled slower code here than the same body as a function).
Unless the user chose a threading layer (`NUMBA_THREADING_LAYER`), numba's GNU OpenMP layer
is tried first, then `workqueue` (`_choose_threading_layer`), and OpenMP's waiting threads
spin only briefly before they sleep (`start_threads`: `GOMP_SPINCOUNT=2000` while numba
loads the layer, unless the user set `GOMP_SPINCOUNT` or `OMP_WAIT_POLICY`). Measured with
`benchmarks/threading_layers.py` (4,096 LCT envs, 2 threads, this 2-core host, ms per step,
median of alternating rounds): idle, `workqueue` 2.18, OpenMP 1.70 (OpenMP's own default
spin, 300,000 rounds: ~1.6); two busy programs beside it, 5.40 and 3.61; nine, 18.2 and
14.1 (spinning 100,000 rounds: 37.6). `workqueue` hands all the work to its threads and
waits; OpenMP's calling thread takes a share (one thread: 2.7 against 3.2 ms per step).
Long spins win only on a host whose cores are the batch's alone: on a 16-core host,
OpenMP's own default scaled better than `workqueue` (16 threads, 8.9-11.2x the one-thread
rate with metrics against 7.1x, from a probe that did not wait for the kernels' loads:
docs/performance.md). numba's `workqueue` layer (the fallback) must
not be entered from two Python threads at once: batches stepped in threads call their
kernels' serial twins (`vector.env`). A process forked from one that loaded OpenMP must not
enter a parallel region at all (`parallel_allowed`).

numba's `math.sin/cos/tan/atan/atan2/tanh/sqrt` call the same C library functions as
CPython's `math` (checked in the tests), and `%` on floats has Python's semantics. Only
`math.hypot` differs (CPython has its own algorithm), hence `py_hypot`.

`NUMBA_DISABLE_JIT=1` runs every kernel as plain Python (for debugging), with the same
results: kernels use only what Python and numba agree on.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import math
import os
import pickle
import queue
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FunctionType
from typing import Any, TypeVar, cast

import numba
import numpy as np
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


def _keep_sys_stdout() -> None:
    """Stop numba from swapping `sys.stdout` behind the program's back.

    Why: where colorama is installed (mkdocs-material brings it), numba colours the text of
    the typing errors it formats, and a compile formats such errors routinely while it tries
    overloads. Each colouring enters colorama's `init`/`deinit`, which replace `sys.stdout`
    and `sys.stderr` process-wide, from whichever thread compiles (our background compile
    thread included), and put back the streams they saw on entry. A program that redirected
    its output meanwhile (a test's capture, a notebook cell, a human session's transcript)
    then writes to the old stream. numba's own switch, `NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING`,
    is read only when numba is imported, and numba's modules keep the colour scheme they got
    then; so this makes that one shared scheme return its text unchanged (no colour codes in
    error messages, which also keeps them readable in logs).
    """
    errors: Any = numba.core.errors
    scheme = errors.termcolor()
    if hasattr(scheme, "_markup"):
        scheme._markup = lambda msg, color=None, style=None: msg


_keep_sys_stdout()


def _choose_threading_layer() -> None:
    """OpenMP, else `workqueue`, else TBB, unless the user chose a layer or an order (see the
    module docstring)."""
    config: Any = numba.config
    chose = os.environ.get("NUMBA_THREADING_LAYER") or os.environ.get("NUMBA_THREADING_LAYER_PRIORITY")
    if not chose and config.THREADING_LAYER == "default":
        config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]


_choose_threading_layer()
_THREADS_STARTED = False
_OMP_WAIT_SETTINGS = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")  # (the user's choice, where set, is kept)


def start_threads() -> None:
    """Load numba's threading layer now (`parallel_kernel` calls it once per process), with
    GNU OpenMP's waiting threads spinning 2,000 rounds before they sleep (see the module
    docstring). OpenMP reads that from the environment once, when numba loads it, so
    `GOMP_SPINCOUNT` is set only for that moment: other OpenMP users of the process (torch's
    own copy of the library) keep their settings. A layer already loaded is left as it is."""
    global _THREADS_STARTED
    if _THREADS_STARTED:
        return
    _THREADS_STARTED = True
    from numba.np.ufunc import parallel

    ours = not any(k in os.environ for k in _OMP_WAIT_SETTINGS)
    if ours:
        os.environ["GOMP_SPINCOUNT"] = "2000"
    try:
        parallel._launch_threads()
    finally:
        if ours:
            os.environ.pop("GOMP_SPINCOUNT", None)


_FORKED_FROM_OPENMP = False  # this process was forked from one that had loaded numba's GNU OpenMP layer


def parallel_allowed() -> bool:
    """Whether this process may enter numba's parallel regions. Not in a process forked from
    one that had loaded numba's GNU OpenMP layer: there its first parallel region ends the
    process ("fork() called from a process already using GNU OpenMP, this is unsafe"), so
    the native batches step with their kernels' serial twins (the same results, on one core).
    Spawned processes (`processes=N` shards, the study runner) start afresh."""
    return not _FORKED_FROM_OPENMP


def _note_fork() -> None:
    global _FORKED_FROM_OPENMP
    if _THREADS_STARTED and not _FORKED_FROM_OPENMP:
        with contextlib.suppress(ValueError):  # (no layer loaded)
            _FORKED_FROM_OPENMP = numba.threading_layer() == "omp"


if hasattr(os, "register_at_fork"):  # (POSIX: elsewhere nothing forks)
    os.register_at_fork(after_in_child=_note_fork)


def _boxed(value: Any) -> Any:
    """A kernel's result as numba returns it to Python: numpy scalars (what a kernel run as
    Python gives for array elements) as Python's float, int and bool, inside tuples too, so
    callers see the same types whichever way the kernel ran (Gymnasium's vector infos, for
    one, build arrays by the type of the first value)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple):
        return tuple(_boxed(v) for v in value)
    return value


_STAND_INS: dict[int, tuple[Any, Callable[..., Any]]] = {}  # `python_stand_in`'s, by the id of what they stand in for


def python_stand_in(compiled_only: Any, python: Callable[..., Any]) -> None:
    """A kernel running as Python (`_Twins`) that finds `compiled_only` among its module's
    globals (a numba intrinsic, which has no Python form, or a kernel whose Python twin is a
    slow copy of a Python builtin) calls `python` instead."""
    _STAND_INS[id(compiled_only)] = (compiled_only, python)


def python_twin(dispatcher: Any) -> Callable[..., Any]:
    """The Python form a kernel runs as while it has no machine code (its twin, `_Twins`), for a
    `python_stand_in` that hands the rest of its work back to the kernel's own code."""
    return _BACKGROUND.twins.of(dispatcher)


_BUFFER_KERNELS: set[int] = set()  # ids of the kernels marked by `python_buffers`


def python_buffers(dispatcher: F) -> F:
    """Mark a kernel whose Python twin (a cold cache, see `_Background`) takes its numpy
    arrays, in tuples too, as memoryviews. Why: indexing a memoryview element by element
    gives Python floats, ints and bools; a numpy array gives numpy scalars, whose arithmetic
    costs several times a float's. The hot loop of a cold 4,096-env platoon batch ran its
    first step in 2.6 s with arrays, 1.7 s with memoryviews (`benchmarks/cold_native.py`).
    The floats are the same: both are IEEE doubles under the same operations, and Python's
    float errors (a division by zero raises) are numba's (its default error model), not
    numpy's. What such a kernel and everything it calls may do with an array: index single
    elements (one integer per dimension), read `shape` and `len`; no sub-views (`a[i]` of a
    2-D array), slices or array methods (memoryviews have none: a test running the kernel
    as Python catches them). A float32 element reads as a double: fine for the marked
    kernels, which only write float32 arrays (observations; a store rounds as numba's
    does) or mix them with doubles (numba then computes in double too), but a kernel that
    chains float32 operations must stay unmarked. Apply it above the kernel decorator."""
    _BUFFER_KERNELS.add(id(dispatcher))
    return dispatcher


_BATCH_KERNELS: set[int] = set()  # ids of the kernels marked by `whole_batch`


def whole_batch(dispatcher: F) -> F:
    """Mark a serial kernel that steps a whole native batch in one call (as every
    `parallel_kernel` does): when the machine's cache holds its code, its first call in a
    process loads it (`_in_cache`) instead of running as Python, which for thousands of envs
    costs a good part of a step. Not for kernels a single env calls: there a Python run costs
    microseconds, while a process's first load also loads numba's typing registries
    (0.3-0.6 s). Apply it above the kernel decorator."""
    _BATCH_KERNELS.add(id(dispatcher))
    return dispatcher


def _as_buffers(value: Any) -> Any:
    """`value` with its numpy arrays (of numbers or bools, one dimension or more), in tuples
    too, as memoryviews (see `python_buffers`)."""
    if isinstance(value, np.ndarray):
        if value.ndim >= 1 and value.dtype.kind in "biuf" and value.dtype.isnative:
            return value.data  # (a memoryview of the array)
        return value
    if isinstance(value, tuple):
        return tuple(_as_buffers(v) for v in value)
    return value


def _on_buffers(twin: Callable[..., Any]) -> Callable[..., Any]:
    def run(*args: Any) -> Any:
        return twin(*(_as_buffers(a) for a in args))

    return run


class _Twins:
    """Each kernel's Python twin: its `py_func` with the kernels it calls (module globals)
    bound to their twins, so that a kernel running as Python calls Python functions directly.
    Through the kernels themselves each nested call would pass numba's dispatcher (typing
    every argument, then `_compile_for_args`), which made a native LCT step of 4,096 envs
    take 3-8 s instead of ~1 s. A twin reads a copy of its module's globals taken at its
    first call: numba too takes globals as constants when it compiles."""

    def __init__(self, ours: set[int]) -> None:
        self.ours = ours  # ids of this module's kernels
        self.made: dict[int, Callable[..., Any]] = {}
        self.spaces: dict[int, dict[str, Any]] = {}

    def of(self, dispatcher: Any) -> Callable[..., Any]:
        twin = self.made.get(id(dispatcher))
        if twin is None:
            fn = dispatcher.py_func
            twin = FunctionType(fn.__code__, self._space(fn.__globals__), fn.__name__, fn.__defaults__, fn.__closure__)
            twin.__kwdefaults__ = fn.__kwdefaults__
            if id(dispatcher) in _BUFFER_KERNELS:
                twin = _on_buffers(twin)
            self.made[id(dispatcher)] = twin
        return twin

    def _space(self, module_globals: dict[str, Any]) -> dict[str, Any]:
        space = self.spaces.get(id(module_globals))
        if space is None:
            space = self.spaces[id(module_globals)] = dict(module_globals)
            for name, value in module_globals.items():
                if id(value) in _STAND_INS:
                    space[name] = _STAND_INS[id(value)][1]
                elif id(value) in self.ours:
                    space[name] = self.of(value)  # (a circle ends at the space or twin already made)
        return space


class _CompileChild:
    """A child Python process (`opends_gym.jit_child`) that compiles kernels into the
    machine's cache, for the background thread to load. Why: numba's compile is mostly
    Python, and in a thread it shares this process's interpreter lock with the steps that
    run as Python meanwhile: each ran at half speed or worse (a native LCT batch's 4,096-env
    step took 3-8 s, and its compile stretched past 9 minutes while the batch stepped on).
    In a child both run at once, on two cores. Any failure (no child, an error in it, a
    kernel it cannot import) returns False and the thread compiles the kernel itself.
    The child ends when this process does (a control pipe closes), unless `detach` handed
    it the compiles still to do."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen[bytes] | None = None
        self.control = -1  # our end of the control pipe
        self.broken = False

    @staticmethod
    def job(dispatcher: Any, signature: tuple[Any, ...]) -> tuple[str, str, tuple[Any, ...]] | None:
        """What the child needs to find and compile a kernel; None for a kernel it cannot import."""
        fn = dispatcher.py_func
        return None if "<locals>" in fn.__qualname__ else (fn.__module__, fn.__qualname__, signature)

    def _start(self) -> subprocess.Popen[bytes]:
        if self.proc is None or self.proc.poll() is not None:
            theirs, self.control = os.pipe()
            try:
                self.proc = subprocess.Popen(
                    [sys.executable, "-m", "opends_gym.jit_child", str(theirs)],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.DEVNULL,
                    pass_fds=(theirs,),
                    env={**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)},
                )
            finally:
                os.close(theirs)
        return self.proc

    def compile(self, dispatcher: Any, signature: tuple[Any, ...]) -> bool:
        job = self.job(dispatcher, signature)
        if self.broken or job is None:
            return False
        try:
            proc = self._start()
            assert proc.stdin is not None and proc.stdout is not None
            pickle.dump(job, proc.stdin)
            proc.stdin.flush()
            return proc.stdout.readline().strip() == b"ok"
        except (OSError, ValueError, pickle.PicklingError, AssertionError):  # (ValueError: a pipe closed by `detach`)
            self.broken = True
            return False

    def forget(self) -> None:
        """In a forked process: close its copies of the pipes to the parent's child, so that
        the child still ends with the parent while the fork lives on."""
        pipes = [self.proc.stdin, self.proc.stdout] if self.proc is not None else []
        devnull = os.open(os.devnull, os.O_RDWR)
        for pipe in pipes:
            with contextlib.suppress(OSError, ValueError):
                if pipe is not None:  # (its fd now /dev/null: `close()` could wait forever on the lock of a read
                    os.dup2(devnull, pipe.fileno())  # the parent's thread was in when it forked)
        os.close(devnull)
        if self.control >= 0:
            with contextlib.suppress(OSError):
                os.close(self.control)
        self.proc, self.control = None, -1

    def detach(self, jobs: list[tuple[str, str, tuple[Any, ...]]]) -> bool:
        """At exit: leave `jobs` to the child, which compiles them (after the one it is on)
        into the cache after this process has gone, then ends. False if there is no child."""
        proc = self.proc
        if proc is None or proc.poll() is not None or proc.stdin is None:
            return False
        try:
            os.write(self.control, b"detach")
            for job in jobs:
                pickle.dump(job, proc.stdin)
            proc.stdin.close()
        except (OSError, ValueError, pickle.PicklingError):
            return False
        return True


def _in_cache(dispatcher: Any, types: tuple[Any, ...]) -> bool:
    """Does the machine's numba cache hold `dispatcher`'s code for `types`, with the current
    kernel sources (`_kernel_sources_stamp`)? Read from the cache's index, without loading.
    Why: a native batch's whole-batch kernels (`parallel_kernel`, `whole_batch`) run as Python at ~1-2 s a
    step of 4,096 brake or platoon envs, while loading them from the cache takes a fraction
    of that, so a process whose cache holds them loads them in the call instead of stepping
    as Python until the background thread has. (A single env's kernels stay in the
    background: as Python they cost milliseconds, while the first load in a process also
    loads numba's typing registries, 0.3-0.6 s.)"""
    cache = getattr(dispatcher, "_cache", None)
    try:
        key = cache._index_key(types, dispatcher.targetctx.codegen())  # type: ignore[union-attr]
        files = cache._cache_file  # type: ignore[union-attr]
        name = files._load_index().get(key)
        return name is not None and os.path.isfile(files._data_path(name))  # (a lost data file would compile in the call)
    except Exception:  # (no cache, or numba's internals changed: the background path)
        return False


class _Background:
    """One daemon thread that compiles (or loads from the cache) the kernels called from
    Python before their machine code exists; meanwhile those calls run the Python function
    (its `_Twins` twin). The thread has each kernel compiled in a child process
    (`_CompileChild`) and then loads it from the cache; a kernel the child cannot compile
    (one it cannot import, a cache it cannot write) the thread compiles itself.

    How: numba's dispatcher, finding no machine code for the argument types of a call, asks
    its `_compile_for_args(*args)` for a callable and calls it; a non-compiled callable is
    called as Python ("re-enter interpreter" in numba's `_dispatcher.cpp`). Each kernel gets
    an instance-level `_compile_for_args` that queues the compile and returns the Python
    function. Kernels called from that Python function (and kernels called while the
    background thread itself compiles) take the same path without queuing: the outer
    kernel's compile compiles them. Once compiled, calls go to the machine code without
    passing here. A compile that fails is retried in the caller's thread, where its error
    is raised as before."""

    def __init__(self) -> None:
        self.hooked: set[int] = set()
        self.twins = _Twins(self.hooked)
        self._fresh()
        self.local = threading.local()
        self.in_call = 0  # > 0 inside `compile_in_call`
        self.python_calls = 0  # top-level kernel calls that ran as Python (a count, for tests)
        self.compiled = 0

    def _fresh(self) -> None:
        """An empty queue and no thread: at start, and in a forked child (the native batch's
        shard workers), which inherits the parent's queue but not its thread."""
        self.jobs: queue.Queue[tuple[Any, tuple[Any, ...]]] = queue.Queue()
        self.queued: set[tuple[int, tuple[Any, ...]]] = set()
        self.failed: set[int] = set()
        self.thread: threading.Thread | None = None
        self.lock = threading.Lock()
        self.busy = threading.Lock()  # held while compiling: a fork waits for it (see below)
        self.stopping = False
        parents: _CompileChild | None = getattr(self, "child", None)
        if parents is not None:  # (a fork: that compile child is the parent's)
            parents.forget()
        self.child = _CompileChild()

    def enabled(self) -> bool:
        return self.in_call == 0 and os.environ.get("OPENDS_GYM_JIT_BACKGROUND", "1") not in ("0", "false", "no")

    def hook(self, dispatcher: Any) -> None:
        original = dispatcher._compile_for_args
        self.hooked.add(id(dispatcher))

        def compile_for_args(*args: Any, **kws: Any) -> Any:
            if getattr(self.local, "python_depth", 0) > 0:  # inside a kernel running as Python
                return dispatcher.py_func
            if threading.current_thread() is self.thread or id(dispatcher) in self.failed or not self.enabled():
                return original(*args, **kws)
            types = tuple(dispatcher.typeof_pyval(a) for a in args)
            if (dispatcher.targetoptions.get("parallel") or id(dispatcher) in _BATCH_KERNELS) and _in_cache(dispatcher, types):
                return original(*args, **kws)  # (a whole-batch kernel: loading it now beats a step of Python, see `_in_cache`)
            self.submit(dispatcher, types)
            stand_in = _STAND_INS.get(id(dispatcher))  # (called from Python too, a stand-in wins over the twin)
            return self._as_python(stand_in[1] if stand_in is not None else self.twins.of(dispatcher))

        dispatcher._compile_for_args = compile_for_args

    def _as_python(self, py_func: Callable[..., Any]) -> Callable[..., Any]:
        def run(*args: Any) -> Any:
            self.python_calls += 1
            self.local.python_depth = getattr(self.local, "python_depth", 0) + 1
            try:
                return _boxed(py_func(*args))
            finally:
                self.local.python_depth -= 1

        return run

    def submit(self, dispatcher: Any, types: tuple[Any, ...]) -> None:
        key = (id(dispatcher), types)
        with self.lock:
            if key in self.queued or self.stopping:
                return
            self.queued.add(key)
            self.jobs.put((dispatcher, types))
            if self.thread is None:
                self.thread = threading.Thread(target=self._work, name="opends-gym-jit", daemon=True)
                self.thread.start()

    def _work(self) -> None:
        while True:
            dispatcher, types = self.jobs.get()
            try:
                if not self.stopping:  # (not under `busy`: a fork need not wait minutes for the child's compile)
                    self.child.compile(dispatcher, types)  # (then loaded from the cache below)
                with self.busy:
                    if not self.stopping:
                        dispatcher.compile(types)
                        self.compiled += 1
            except Exception:  # the caller's thread compiles it again and raises
                self.failed.add(id(dispatcher))
            finally:
                self.jobs.task_done()

    def wait(self) -> None:
        """Block until every queued compile has finished."""
        self.jobs.join()

    def pending(self) -> int:
        return self.jobs.unfinished_tasks

    def finish(self, timeout_s: float = 120.0) -> None:
        """At exit: let the queued compiles finish, so their machine code lands in the cache
        and the next process loads it instead of running Python; a short-lived process (one
        `opends-gym run`) would otherwise never fill the cache. They go to the compile child,
        which finishes them after this process has gone (a native batch's take minutes); this
        process waits at most `timeout_s` for those the child cannot take."""
        if self.thread is None or not self.pending():
            return
        rest: list[tuple[Any, tuple[Any, ...]]] = []  # (kernel, argument types) the child cannot take
        handed: list[tuple[tuple[Any, tuple[Any, ...]], tuple[str, str, tuple[Any, ...]]]] = []  # and the child's job for each
        while True:
            try:
                item = self.jobs.get_nowait()
            except queue.Empty:
                break
            self.jobs.task_done()
            job = self.child.job(*item)
            if job is None:
                rest.append(item)
            else:
                handed.append((item, job))
        detached = self.child.detach([job for _, job in handed])
        if detached and not rest:
            self.stopping = True  # (the thread may be waiting on the child's current compile: not for us to wait)
            return
        for item in rest if detached else rest + [item for item, _ in handed]:
            self.jobs.put(item)
        done = threading.Event()

        def join() -> None:
            self.jobs.join()
            done.set()

        threading.Thread(target=join, daemon=True).start()
        done.wait(timeout_s)
        self.stopping = True  # (a compile still running is cut off with the process: numba writes its cache files whole or not at all)


_BACKGROUND = _Background()
atexit.register(_BACKGROUND.finish)
if hasattr(os, "register_at_fork"):
    # a fork (the native batch's shard workers) waits for the compile in progress: the child
    # would inherit numba's compiler lock held by a thread it does not have
    os.register_at_fork(
        before=lambda: _BACKGROUND.busy.acquire(),
        after_in_parent=lambda: _BACKGROUND.busy.release(),
        after_in_child=_BACKGROUND._fresh,
    )


def wait_compiled() -> None:
    """Block until the kernels queued for background compilation are compiled (benchmarks
    and tests call this; a program never needs to)."""
    _BACKGROUND.wait()


@contextlib.contextmanager
def compile_in_call() -> Iterator[None]:
    """Inside, kernels without machine code compile in their call, as numba does, instead of
    running as Python meanwhile: for `opends-gym compile`, whose native batches would
    otherwise step as Python until the compile child is done."""
    _BACKGROUND.in_call += 1
    try:
        yield
    finally:
        _BACKGROUND.in_call -= 1


def compile_status() -> dict[str, int]:
    """How the kernels ran so far in this process: `python_calls` (kernel calls that ran as
    Python while their compile was pending), `compiled` (background compiles finished),
    `pending` (queued or running)."""
    return {"python_calls": _BACKGROUND.python_calls, "compiled": _BACKGROUND.compiled, "pending": _BACKGROUND.pending()}


_KERNELS: list[Any] = []  # every kernel this module made, for `cache_stats`


def cache_stats() -> dict[str, int]:
    """What numba did for this package's kernels in this process: `loaded` (machine code
    taken from the machine's cache) and `compiled` (compiled here: not in the cache), counted
    per kernel and argument types. After `opends-gym compile`, a first step compiles nothing."""
    loaded = compiled = 0
    for dispatcher in _KERNELS:
        stats = getattr(dispatcher, "stats", None)  # (NUMBA_DISABLE_JIT: a plain function)
        if stats is not None:
            loaded += sum(stats.cache_hits.values())
            compiled += sum(stats.cache_misses.values())
    return {"loaded": loaded, "compiled": compiled}


def _background(dispatcher: Any) -> Any:
    _KERNELS.append(dispatcher)
    if hasattr(dispatcher, "_compile_for_args"):  # (NUMBA_DISABLE_JIT: a function)
        _BACKGROUND.hook(dispatcher)
    return dispatcher


def kernel(fn: F) -> F:
    """Compile `fn` with the project's numba settings (see the module docstring)."""
    return cast(F, _background(njit(cache=True, nogil=True)(fn)))


def parallel_kernel(fn: F) -> F:
    """A `kernel` whose `prange` loops run in parallel (see the module docstring); numba's
    threads start with the first such kernel a process defines (`start_threads`)."""
    start_threads()
    return cast(F, _background(njit(cache=True, nogil=True, parallel=True)(fn)))


def borrowing_kernel(fn: F) -> F:
    """A `kernel` compiled without numba's reference counting (`_nrt=False`), for the hottest
    loops: every inlined helper that takes arrays otherwise updates their reference counts
    (atomic operations) at each call, ~15 % of the traffic step's time. Such a kernel must not
    allocate (no `np.empty`, no array-returning numpy call); the arrays it indexes are its
    arguments, which its caller keeps alive."""
    options: dict[str, Any] = {"cache": True, "nogil": True, "_nrt": False}  # (`_nrt`: numba's own option, not in its stubs)
    return cast(F, _background(njit(**options)(fn)))


def inline(fn: F) -> F:
    """A `kernel` that is inlined into the kernels calling it: a call between compiled
    functions passes every array as a struct of seven words and updates its reference count,
    which costs more than the small helpers themselves. Call it only from kernels (numba
    would compile it afresh in every process that calls it from Python)."""
    return cast(F, _background(njit(cache=True, nogil=True, inline="always")(fn)))


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


if sys.implementation.name == "cpython" and sys.version_info[:2] == (3, 11):
    # kernels running as Python (a cold cache) call CPython's own `math.hypot`, which `py_hypot`
    # copies (its Python twin took ~8 us a call: ~5 % of a cold 4,096-env brake step)
    python_stand_in(py_hypot, math.hypot)
