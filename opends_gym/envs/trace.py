"""Per-physics-step trace of an episode, the input of the end-of-episode metrics.

Why: SDLP, reversal rate, mean deviation and LCT MDEV are functions of whole traces; we
keep one compact float array per episode (grown by doubling) instead of Python lists.
"""

from __future__ import annotations

import itertools

import numpy as np

COLUMNS = (
    "t_s",
    "x_m",
    "z_m",
    "yaw_rad",
    "speed_mps",
    "lateral_m",
    "lane_offset_m",
    "lane_index",
    "steering",
    "accelerator",
    "brake",
    "headway_s",
    "ttc_s",
    "gap_m",  # bumper to bumper to the lead vehicle (inf without one)
    "lead_speed_mps",  # the lead's speed along the ego's heading (NaN without one)
)
COL = {name: i for i, name in enumerate(COLUMNS)}


FLUSH_ROWS = 256  # rows gathered in a list before they are copied into the array


class Trace:
    """Rows are appended to a short Python list (cheap per step) and copied into the float
    array in blocks; `col()` flushes first, `last()` reads the newest row directly."""

    def __init__(self, capacity: int = 4096) -> None:
        self._data = np.zeros((capacity, len(COLUMNS)), dtype=np.float64)
        self._stored = 0  # rows already in `_data`
        self._rows: list[tuple[float, ...]] = []  # rows appended since the last flush
        self._last: tuple[float, ...] = ()
        self.n = 0

    def clear(self) -> None:
        self.n = 0
        self._stored = 0
        self._rows.clear()
        self._last = ()

    def append(self, row: tuple[float, ...]) -> None:
        self._rows.append(row)
        self._last = row
        self.n += 1
        if len(self._rows) >= FLUSH_ROWS:
            self._flush()

    def _flush(self) -> None:
        rows = self._rows
        if not rows:
            return
        end = self._stored + len(rows)
        while end > len(self._data):
            self._data = np.concatenate([self._data, np.zeros_like(self._data)])
        flat = np.fromiter(itertools.chain.from_iterable(rows), dtype=np.float64, count=len(rows) * len(COLUMNS))
        self._data[self._stored : end] = flat.reshape(len(rows), len(COLUMNS))  # (faster than from the tuples)
        self._stored = end
        rows.clear()

    def col(self, name: str) -> np.ndarray:
        self._flush()
        return self._data[: self.n, COL[name]]

    def last_row(self) -> tuple[float, ...]:
        """The newest row as appended (empty before the first)."""
        return self._last

    def last(self, name: str) -> float:
        return float(self._last[COL[name]]) if self.n else float("nan")
