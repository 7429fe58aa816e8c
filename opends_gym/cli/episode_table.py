"""`opends-gym run`'s outputs: the per-episode table and the `--csv` file.

Why: one column per episode was 427 characters wide at 30 episodes. Episodes are rows
here (metrics that differ between episodes as columns, wrapped to the terminal width),
with mean, SD and the 95 % t-interval as rows under them; metrics that are the same in
every episode are listed once. The CSV has one row per episode and a column per metric,
the long format R's `read.csv` and pandas' `read_csv` take as it is.
"""

from __future__ import annotations

import csv
import math
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

INDEX = ("episode", "seed", "end")


def fmt(v: Any) -> str:
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def sd(values: Iterable[Any]) -> float:
    """Sample standard deviation of the finite numbers (nan below two)."""
    v = [float(x) for x in values if isinstance(x, (int, float)) and math.isfinite(float(x))]
    if len(v) < 2:
        return math.nan
    m = sum(v) / len(v)
    return math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1))


def _end(episode: dict[str, Any]) -> str:
    return "terminated" if episode["terminated"] else "truncated"


def _blocks(keys: list[str], widths: dict[str, int], room: int) -> list[list[str]]:
    """Split metric columns into blocks that fit `room` characters beside the index."""
    blocks: list[list[str]] = [[]]
    used = 0
    for k in keys:
        if blocks[-1] and used + widths[k] > room:
            blocks.append([])
            used = 0
        blocks[-1].append(k)
        used += widths[k]
    return blocks


def table_lines(result: dict[str, Any], line_width: int | None = None) -> list[str]:
    """The text tables of a `run` result (see the module docstring)."""
    eps = result["episodes"]
    summary = result["summary"]
    keys = [k for k in summary if k != "wall_s"]  # the host's speed, not the drive's: one line at the end
    width = line_width or max(60, shutil.get_terminal_size((100, 24)).columns)
    lines = [f"{result['env_id']}  agent={result['agent']}  episodes={len(eps)}"]
    varying = [k for k in keys if len({fmt(e.get(k, "")) for e in eps}) > 1]
    if varying:
        rows = [{"episode": str(e["episode"]), "seed": str(e["seed"]), "end": _end(e)} for e in eps]
        foot_labels = ("mean", "sd", "95% CI low", "95% CI high")
        foot: dict[str, dict[str, str]] = {name: {} for name in foot_labels}
        for k in varying:
            s = summary[k]
            foot["mean"][k], foot["sd"][k] = fmt(s["mean"]), fmt(s.get("sd", math.nan))
            foot["95% CI low"][k], foot["95% CI high"][k] = fmt(s["low"]), fmt(s["high"])
            for row, e in zip(rows, eps):
                row[k] = fmt(e.get(k, ""))
        iw = {c: max(len(c), *(len(r[c]) for r in rows)) + 2 for c in INDEX}
        index_w = max(sum(iw.values()), *(len(label) + 2 for label in foot_labels))
        iw["end"] += index_w - sum(iw.values())
        cw = {k: max(len(k), *(len(r[k]) for r in rows), *(len(foot[f][k]) for f in foot_labels)) + 2 for k in varying}
        for block in _blocks(varying, cw, max(10, width - index_w)):
            lines.append("")
            lines.append("".join(c.ljust(iw[c]) for c in INDEX) + "".join(k.rjust(cw[k]) for k in block))
            for row in rows:
                lines.append("".join(row[c].ljust(iw[c]) for c in INDEX) + "".join(row[k].rjust(cw[k]) for k in block))
            lines.append("-" * (index_w + sum(cw[k] for k in block)))
            for label in foot_labels:
                lines.append(label.ljust(index_w) + "".join(foot[label][k].rjust(cw[k]) for k in block))
    same = [k for k in keys if k not in varying]
    if same:
        lines.append("")
        lines.append("same in every episode:" if len(eps) > 1 else "metrics:")
        kw = max(len(k) for k in same) + 2
        lines.extend("  " + k.ljust(kw) + fmt(eps[0].get(k, "")) for k in same)
    wall = [float(e["wall_s"]) for e in eps if "wall_s" in e]
    if wall:
        lines.append("")
        lines.append(f"wall time {sum(wall):.3g} s ({sum(wall) / len(wall):.3g} s per episode)")
    return lines


def _csv_cell(v: Any) -> Any:
    """R and pandas spellings: NA for missing or NaN, Inf/-Inf, TRUE/FALSE."""
    if v is None:
        return "NA"
    if isinstance(v, bool):
        return "TRUE" if v else "FALSE"
    if isinstance(v, float):
        if math.isnan(v):
            return "NA"
        if math.isinf(v):
            return "Inf" if v > 0 else "-Inf"
        return repr(v)
    return v


def write_csv(result: dict[str, Any], path: str | Path) -> Path:
    """One row per episode: env, task, agent, seed, episode, then every metric."""
    head = ["env", "task", "agent", "seed", "episode"]
    columns: dict[str, None] = {}
    for e in result["episodes"]:
        columns.update((k, None) for k in e if k not in ("seed", "episode"))
    out = Path(path)
    with out.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(head + list(columns))
        for e in result["episodes"]:
            fixed = [result["env_id"], result.get("task", ""), result["agent"], e["seed"], e["episode"]]
            w.writerow([_csv_cell(v) for v in fixed] + [_csv_cell(e.get(k)) for k in columns])
    return out
