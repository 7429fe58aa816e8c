"""Which kernels make a native batch's cold compile long? CPU seconds per compiled function.

Run it with an empty numba cache, or it times cache loads instead of compiles:

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_profile.py [OpenDS/LaneChangeTest-v0] [--envs 300] [--top 12]

It makes the native batch, resets it and steps it three times with the background compile off
(`OPENDS_GYM_JIT_BACKGROUND=0`), listening to numba's compile events. A function's time
includes the functions it compiled on the way (nested compiles), so the list is not a sum.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from typing import Any

from numba.core import event


class _CompileTimes(event.Listener):
    """CPU seconds from each dispatcher's compile start to its end."""

    def __init__(self) -> None:
        self.started: dict[int, tuple[float, str]] = {}
        self.times: list[tuple[float, str]] = []

    def on_start(self, ev: Any) -> None:
        d = ev.data["dispatcher"]
        self.started[id(d)] = (time.process_time(), d.py_func.__qualname__)

    def on_end(self, ev: Any) -> None:
        t0, name = self.started.pop(id(ev.data["dispatcher"]), (None, ""))
        if t0 is not None:
            self.times.append((time.process_time() - t0, name))


def _time_sealed_workers(listener: _CompileTimes) -> None:
    """Count the compiles of `sealed.SealedWorker`s too (numba `cfunc`s send no compile event)."""
    from opends_gym.vector.sealed import SealedWorker

    at = SealedWorker.at

    def timed(self: SealedWorker, args: tuple) -> tuple[int, int]:  # type: ignore[type-arg]
        t0 = time.process_time()
        out = at(self, args)
        seconds = time.process_time() - t0
        if seconds > 0.01:  # (compiled or loaded from the cache now, not looked up)
            listener.times.append((seconds, f"{self.fn.__qualname__} (SealedWorker)"))
        return out

    SealedWorker.at = timed  # type: ignore[method-assign]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("env_id", nargs="?", default="OpenDS/LaneChangeTest-v0")
    parser.add_argument("--envs", type=int, default=300)
    parser.add_argument("--top", type=int, default=12)
    args = parser.parse_args()
    os.environ["OPENDS_GYM_JIT_BACKGROUND"] = "0"
    logging.disable(logging.WARNING)
    listener = _CompileTimes()
    event.register("numba:compile", listener)
    _time_sealed_workers(listener)
    import gymnasium as gym

    import opends_gym  # noqa: F401  (registers the ids)

    t0 = time.process_time()
    env = gym.make_vec(args.env_id, num_envs=args.envs, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(3):
        env.step(env.action_space.sample())
    env.close()
    print(f"{args.env_id}, {args.envs} envs: {time.process_time() - t0:.1f} CPU s to make, reset and step 3 times")
    print("CPU s  function (nested compiles included)")
    for seconds, name in sorted(listener.times, reverse=True)[: args.top]:
        print(f"{seconds:6.1f}  {name}")


if __name__ == "__main__":
    main()
