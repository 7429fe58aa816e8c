"""Numbers and warnings for the network protocols (CAN gateway, settings controller).

Why: Python's `float`/`int` accept far more than a peer should send: `"١٢"` (Arabic-Indic
digits), `"１０"` (full-width) and `"1_0"` (an underscore) all parse, so `channel0="1_0"`
meant full steering lock. OpenDS's own tools send plain ASCII decimals, so only those are
numbers here. And a peer that sends garbage 200 times a second must not fill the log with
one WARNING each: `RateLimitedWarning` lets one through per interval and counts the rest.
"""

from __future__ import annotations

import logging
import re
import threading
import time

_FLOAT = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_INT = re.compile(r"[+-]?\d+", re.ASCII)


def ascii_float(text: str) -> float:
    """A decimal number in ASCII digits (`-92`, `0.5`, `1e-3`); anything else is ValueError.

    The result may still be inf for a huge exponent: callers check their ranges."""
    t = text.strip()
    if len(t) > 64 or not _FLOAT.fullmatch(t):
        raise ValueError("not a number")
    return float(t)


def ascii_int(text: str) -> int:
    """A whole number in ASCII digits, at most 18 of them; anything else is ValueError."""
    t = text.strip()
    if len(t) > 19 or not _INT.fullmatch(t):
        raise ValueError("not an integer")
    return int(t)


class RateLimitedWarning:
    """At most one WARNING per `interval_s` on `logger`; the next one says how many were held back."""

    def __init__(self, logger: logging.Logger, interval_s: float = 5.0, clock: object = time.monotonic) -> None:
        self.logger = logger
        self.interval_s = interval_s
        self._clock = clock
        self._next = -float("inf")
        self.suppressed = 0  # since the last emitted warning
        self.total = 0  # every warning asked for
        self._lock = threading.Lock()

    def warn(self, message: str, *args: object) -> bool:
        """Log `message % args` unless one was logged within `interval_s`; True when logged."""
        now = self._clock()  # type: ignore[operator]
        with self._lock:
            self.total += 1
            if now < self._next:
                self.suppressed += 1
                return False
            held, self.suppressed = self.suppressed, 0
            self._next = now + self.interval_s
        if held:
            self.logger.warning(message + " (%d similar message(s) suppressed in the last %g s)", *args, held, self.interval_s)
        else:
            self.logger.warning(message, *args)
        return True
