"""A one-line progress bar on stderr for multi-episode runs (no extra dependency).

Why: a 100-episode run must show it is alive without tqdm (an `rl` extra) and without
mixing into stdout, which stays for the tables or the JSON. It draws only on a terminal
(or when forced), so logs and pipes get no carriage-return noise.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


class ProgressBar:
    """`episode 3/10 [######..............]  30%  4.1 s, ~9.5 s left`, redrawn in place."""

    def __init__(self, total: int, *, label: str = "episode", stream: TextIO | None = None, enabled: bool | None = None) -> None:
        self.total = total
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:  # auto: only on a terminal, only when there is more than one step
            enabled = total > 1 and bool(getattr(self.stream, "isatty", lambda: False)())
        self.enabled = enabled
        self.start = time.perf_counter()
        self.drawn = False
        self.width = 0

    def update(self, done: int, note: str = "") -> None:
        """Show `done` of `total` finished (and a short note such as the last return)."""
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        frac = done / self.total if self.total else 1.0
        bar = "#" * int(round(20 * frac))
        left = f", ~{elapsed / done * (self.total - done):.1f} s left" if 0 < done < self.total else ""
        line = f"{self.label} {done}/{self.total} [{bar:<20}] {100 * frac:3.0f}%  {elapsed:.1f} s{left}"
        if note:
            line += f"  {note}"
        self.stream.write("\r" + line.ljust(self.width))  # spaces wipe what a longer line left behind
        self.width = len(line)
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """End the bar's line so the next output starts on a fresh one."""
        if self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False
