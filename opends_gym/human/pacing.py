"""Wall-clock pacing of fixed physics steps: real time, catch-up limits, holds, `--fast`.

Why: the simulation advances in fixed steps of simulation time (docs/architecture.md#simulation-time);
a human needs those steps to happen at the rate of the wall clock. Step k is due at
`origin + k * dt`. When drawing a frame takes longer than a step, the next loop runs
several steps to catch up, but never more than `max_catch_up_steps` at once: beyond
that the lag is dropped (the drive slows down for a moment rather than jumping), and
counted. Holds (pause, instruction screens, an unplugged wheel) move the origin so the
time spent holding is not made up afterwards. This is the only wall-clock code of a
human session; the World never sees it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass
class PacingStats:
    steps: int = 0
    catch_up_loops: int = 0  # loops that ran more than one step
    dropped_s: float = 0.0  # lag given up because it exceeded the catch-up limit
    max_lag_s: float = 0.0
    held_s: float = 0.0


class PacingClock:
    """Decides how many physics steps are due (see the module docstring)."""

    def __init__(
        self,
        dt_s: float,
        fast: bool = False,
        max_catch_up_steps: int = 6,
        fast_batch: int = 1,
        now: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if dt_s <= 0:
            raise ValueError("dt_s must be positive")
        self.dt_s = dt_s
        self.fast = fast
        self.max_catch_up_steps = max(1, int(max_catch_up_steps))
        self.fast_batch = max(1, int(fast_batch))
        self._now = now
        self._sleep = sleep
        self.origin = now()
        self.done = 0
        self.stats = PacingStats()
        self._held_since: float | None = None

    def steps_due(self) -> int:
        """Steps to run now; the caller reports them with `advance`."""
        if self._held_since is not None:
            self.release()
        if self.fast:
            return self.fast_batch
        now = self._now()
        due = int((now - self.origin) / self.dt_s) - self.done
        lag = now - (self.origin + self.done * self.dt_s)
        self.stats.max_lag_s = max(self.stats.max_lag_s, lag)
        if due > self.max_catch_up_steps:
            drop = due - self.max_catch_up_steps
            self.origin += drop * self.dt_s
            self.stats.dropped_s += drop * self.dt_s
            due = self.max_catch_up_steps
        if due > 1:
            self.stats.catch_up_loops += 1
        return max(0, due)

    def advance(self, steps: int) -> None:
        self.done += steps
        self.stats.steps += steps

    def wait(self, max_wait_s: float = 0.05) -> None:
        """Sleep until the next step is due (at most `max_wait_s`, to stay responsive)."""
        if self.fast:
            self._sleep(0)  # lets device threads (sockets, buses) run between steps
            return
        delay = self.origin + (self.done + 1) * self.dt_s - self._now()
        if delay > 0:
            self._sleep(min(delay, max_wait_s))

    def hold(self) -> None:
        """The drive is held this loop; the time will not be made up."""
        if self._held_since is None:
            self._held_since = self._now()

    def release(self) -> None:
        if self._held_since is None:
            return
        held = self._now() - self._held_since
        self.stats.held_s += held
        self.origin += held
        self._held_since = None

    @property
    def holding(self) -> bool:
        return self._held_since is not None
