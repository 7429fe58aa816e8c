"""`EpisodeTable`s to and from per-episode dicts, and the vector env's `episode_metrics` info of tables.

Why: the batch cores hand ended episodes' metrics over as one table per step
(`episode_table.EpisodeTable`), so no Python runs per episode between the compiled scoring
and the info arrays; the per-episode dicts (`episodes_metrics`, the single env's form)
are built from the table only where a caller asks for them.
"""

from __future__ import annotations

import functools
import math
import sys
from typing import Any

import numpy as np

from ..jit import kernel
from .episode_table import EpisodeTable


def table_rows(table: EpisodeTable) -> list[dict[str, float]]:
    """The table's rows as dicts (keys in the table's order, absent keys left out; NaN as
    `math.nan`, as the single env's metrics give it)."""
    values = table.values.tolist()
    keys = table.keys
    rows = [{k: math.nan if v != v else v for k, v in zip(keys, row, strict=True)} for row in values]
    if table.present is not None:
        for row, mask in zip(rows, table.present.tolist(), strict=True):
            for k, ok in zip(keys, mask, strict=True):
                if not ok:
                    del row[k]
    return rows


def table_of_rows(rows: list[dict[str, Any]]) -> EpisodeTable:
    """Per-episode dicts of numbers as one table: the union of their keys in order of first
    appearance (`env._metrics_arrays`' order), absent keys 0.0 and not present."""
    order: dict[str, int] = {}
    for row in rows:
        for key in row:
            order.setdefault(key, len(order))
    keys = tuple(order)
    values = np.zeros((len(rows), len(keys)))
    if all(tuple(row) == keys for row in rows):
        for j, row in enumerate(rows):
            values[j] = tuple(row.values())
        return EpisodeTable(keys, values, None)
    present = np.zeros((len(rows), len(keys)), dtype=np.bool_)
    for j, row in enumerate(rows):
        at = [order[key] for key in row]
        values[j, at] = tuple(row.values())
        present[j, at] = True
    return EpisodeTable(keys, values, present)


class InfoBlocks:
    """Reusable (env, key) blocks for `metrics_arrays`: a step's `episode_metrics` arrays are
    columns of two blocks, and zeroing two fresh dense blocks of keys x envs for the few envs
    that ended cost ~140 µs per step at 4,096 envs (~35 ns per env-step). A block is taken
    again only when nothing outside holds it (`sys.getrefcount`: every array handed out is a
    view whose base is the block, so a caller that keeps any of a step's arrays, or the
    info dict, keeps its blocks out of reuse); then only the cells written last time are
    cleared. Blocks a caller holds are never written again. Env-major, so that an ended
    episode's keys are one run of memory: in a (key, env) block each of its cells was a cache
    line of its own (clearing and writing ~190 platoon episodes' cells took ~0.5 ms a step)."""

    POOL = 4  # blocks kept: the caller's last info holds one pair, the one before is free again

    def __init__(self) -> None:
        self._pool: list[list] = []  # [values block, mask block, keys written, envs written]

    def take(self, keys: int, n: int, envs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(values, masks) of at least `keys` rows of `n` envs, zero and False, for writing
        the rows of `envs` (the cells to clear next time)."""
        small = -1  # a free entry too small for `keys`: replaced by a larger one
        for i, entry in enumerate(self._pool):
            columns, masks, k_old, e_old = entry
            # only the pool holds a block: its refs are the entry, the local name and getrefcount's argument
            if sys.getrefcount(columns) != 3 or sys.getrefcount(masks) != 3 or columns.shape[0] != n:
                continue
            if columns.shape[1] < keys:
                small = i
                continue
            _clear_cells(columns, masks, k_old, e_old)
            entry[2], entry[3] = keys, envs
            return columns, masks
        columns, masks = np.zeros((n, keys)), np.zeros((n, keys), dtype=np.bool_)
        if small >= 0:
            self._pool[small] = [columns, masks, keys, envs]
        elif len(self._pool) < self.POOL:
            self._pool.append([columns, masks, keys, envs])
        return columns, masks


def metrics_arrays(tables: list[tuple[list[int], EpisodeTable]], n: int, blocks: InfoBlocks | None = None) -> dict[str, Any]:
    """`episode_metrics` info of the tables (each with its rows' envs in the whole batch):
    each key's float64 column over the n envs and its `_key` mask, keys in order of first
    appearance over the rows (what `env._metrics_arrays` gives for the same rows as dicts of
    floats; strided views of an (env, key) block, not contiguous arrays). `blocks`: reuse the
    blocks the caller no longer holds."""
    if len(tables) == 1:  # (one shard: its table's keys are the order)
        order = dict(zip(tables[0][1].keys, range(len(tables[0][1].keys))))
    else:
        order = {}
        for _, table in tables:
            for key in table.keys:
                order.setdefault(key, len(order))
    if blocks is None:
        columns, masks = np.zeros((n, len(order))), np.zeros((n, len(order)), dtype=np.bool_)
    else:
        written = np.concatenate([np.asarray(envs, dtype=np.int64) for envs, _ in tables])
        columns, masks = blocks.take(len(order), n, written)
    for envs, table in tables:
        rows = np.asarray(envs, dtype=np.int64)
        at_keys = np.fromiter((order[k] for k in table.keys), dtype=np.int64, count=len(table.keys))
        present = _NO_PRESENT if table.present is None else np.ascontiguousarray(table.present)
        _scatter_rows(columns, masks, at_keys, rows, np.ascontiguousarray(table.values, dtype=np.float64), present)
    views: list[np.ndarray] = [columns] * (2 * len(order))  # (iterating a transposed block gives its columns as views, in C)
    views[0::2], views[1::2] = list(columns.T[: len(order)]), list(masks.T[: len(order)])
    return dict(zip(_names(tuple(order)), views, strict=True))


_NO_PRESENT = np.ones((0, 0), dtype=np.bool_)  # (`_scatter_rows`' present of a table whose every key is present)


@kernel
def _clear_cells(columns: np.ndarray, masks: np.ndarray, keys: int, envs: np.ndarray) -> None:
    """Zero the cells 0..keys-1 of the rows `envs` of both blocks: the cells a step wrote."""
    for e in envs:
        for k in range(keys):
            columns[e, k] = 0.0
            masks[e, k] = False


@kernel
def _scatter_rows(columns: np.ndarray, masks: np.ndarray, at_keys: np.ndarray, rows: np.ndarray, values: np.ndarray,
                  present: np.ndarray) -> None:  # fmt: skip
    """Table row j into block row rows[j], its key i at cell at_keys[i]: the value (0.0 where
    `present` says absent; an empty `present`: all present) and its mask."""
    every = present.shape[0] == 0
    for j in range(len(rows)):
        e = rows[j]
        for i in range(len(at_keys)):
            ok = every or present[j, i]
            columns[e, at_keys[i]] = values[j, i] if ok else 0.0
            masks[e, at_keys[i]] = ok


@functools.lru_cache(maxsize=64)
def _names(keys: tuple[str, ...]) -> tuple[str, ...]:
    """Each key then its `_key` mask name (a step's keys repeat: the few layouts of a task)."""
    return tuple(name for key in keys for name in (key, f"_{key}"))
