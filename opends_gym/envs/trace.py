"""Per-physics-step trace of an episode, the input of the end-of-episode metrics.

Why: SDLP, reversal rate, mean deviation and LCT MDEV are functions of whole traces; we
keep one compact float array per episode (grown by doubling) instead of Python lists.
"""

from __future__ import annotations

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
)
COL = {name: i for i, name in enumerate(COLUMNS)}


class Trace:
    def __init__(self, capacity: int = 4096) -> None:
        self._data = np.zeros((capacity, len(COLUMNS)), dtype=np.float64)
        self.n = 0

    def clear(self) -> None:
        self.n = 0

    def append(self, row: tuple[float, ...]) -> None:
        if self.n == len(self._data):
            self._data = np.concatenate([self._data, np.zeros_like(self._data)])
        self._data[self.n] = row
        self.n += 1

    def col(self, name: str) -> np.ndarray:
        return self._data[: self.n, COL[name]]

    def last(self, name: str) -> float:
        return float(self._data[self.n - 1, COL[name]]) if self.n else float("nan")
