"""`EpisodeTable`s to and from per-episode dicts, and the vector env's `episode_metrics` info of tables.

Why: the batch cores hand ended episodes' metrics over as one table per step
(`episode_table.EpisodeTable`), so no Python runs per episode between the compiled scoring
and the info arrays; the per-episode dicts (`episodes_metrics`, the single env's form)
are built from the table only where a caller asks for them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

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


def metrics_arrays(tables: list[tuple[list[int], EpisodeTable]], n: int) -> dict[str, Any]:
    """`episode_metrics` info of the tables (each with its rows' envs in the whole batch):
    each key's float64 column over the n envs and its `_key` mask, keys in order of first
    appearance over the rows (what `env._metrics_arrays` gives for the same rows as dicts of
    floats)."""
    order: dict[str, int] = {}
    for _, table in tables:
        for key in table.keys:
            order.setdefault(key, len(order))
    columns, masks = np.zeros((len(order), n)), np.zeros((len(order), n), dtype=np.bool_)
    for envs, table in tables:
        rows = np.asarray(envs, dtype=np.intp)
        values = table.values if table.present is None else np.where(table.present, table.values, 0.0)  # (absent: 0, as there)
        at_keys = np.fromiter((order[k] for k in table.keys), dtype=np.intp, count=len(table.keys))
        if (at_keys == np.arange(len(at_keys))).all():  # (the usual case: the keys first and in order, plain row slices)
            columns[: len(at_keys), rows] = values.T
            masks[: len(at_keys), rows] = True if table.present is None else table.present.T
        else:
            columns[at_keys[:, None], rows[None, :]] = values.T
            masks[at_keys[:, None], rows[None, :]] = True if table.present is None else table.present.T
    out: dict[str, Any] = {}
    for j, key in enumerate(order):
        out[key], out[f"_{key}"] = columns[j], masks[j]
    return out
