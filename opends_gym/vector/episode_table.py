"""One table of ended episodes' metrics (rows: episodes; columns: metric keys), handed from a batch core to the vector env
without a dict per episode."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EpisodeTable:
    keys: tuple[str, ...]
    values: np.ndarray  # float64 (episodes, keys)
    present: np.ndarray | None  # bool (episodes, keys); None: every key present in every row
