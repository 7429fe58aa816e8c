"""The long-format study table on disk: CSV and Parquet, virtual and human rows side by side.

Why long format (one row per participant, source, condition, task, trial, metric): every
statistics package reads it, a human's blocks append to it without reshaping, and a metric
some episodes lack is a missing row, not a column of blanks.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..extras import require
from .runner import COLUMNS, Row

VIRTUAL_ROWS = "virtual.csv"
TABLE = "table"  # table.csv and table.parquet


def write_rows(path: Path, rows: Iterable[Row]) -> Path:
    """Write rows as CSV atomically (a temporary file renamed: a crash never leaves half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    with tmp.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([*r[:6], repr(float(r[6]))])
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return path


def read_rows(path: Path) -> list[Row]:
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None or tuple(header) != COLUMNS:
            raise ValueError(f"{path}: not a study table (columns {header}, expected {', '.join(COLUMNS)})")
        return [(a, b, c, d, int(e), m, float(v)) for a, b, c, d, e, m, v in reader]


def row_files(out: Path) -> list[Path]:
    """The virtual rows and every human block of a study folder, in a fixed order."""
    files = [out / VIRTUAL_ROWS] if (out / VIRTUAL_ROWS).is_file() else []
    human = out / "human"
    if human.is_dir():
        files += sorted(human.glob("*/blocks/*.csv"))
    return files


def collect(out: Path) -> Any:
    """Every row of the study folder as a pandas DataFrame with the table's columns."""
    pd = require("study", "pandas", "the study table")
    rows = [r for f in row_files(out) for r in read_rows(f)]
    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    return frame.astype({"trial": "int64", "value": "float64"})


def write_table(out: Path) -> tuple[Path, Path, Any]:
    """table.csv and table.parquet from every row file of `out`; returns both paths and the frame."""
    require("study", "pyarrow", "the study table's Parquet file")
    frame = collect(out)
    csv_path, parquet_path = out / f"{TABLE}.csv", out / f"{TABLE}.parquet"
    tmp = out / f"{TABLE}.csv.part"
    frame.to_csv(tmp, index=False, float_format="%.17g")
    os.replace(tmp, csv_path)
    tmp = out / f"{TABLE}.parquet.part"
    frame.to_parquet(tmp, index=False)
    os.replace(tmp, parquet_path)
    return csv_path, parquet_path, frame
