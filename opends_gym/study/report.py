"""The study's HTML report: the effects table and one figure per task and metric, PNGs embedded.

Why one self-contained file: it is mailed and archived with the data; nothing to lose.
"""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..extras import require
from .analysis import Effect, power_at

EFFECT_COLUMNS = (
    ("source", "source"),
    ("task", "task"),
    ("metric", "metric"),
    ("condition", "condition"),
    ("n", "n"),
    ("mean_reference", "reference mean (SD)"),
    ("mean_condition", "condition mean (SD)"),
    ("difference", "difference [95 % CI]"),
    ("cohens_dz", "Cohen's d_z [95 % CI]"),
    ("mixedlm_coef", "MixedLM coef [95 % CI], p"),
    ("power_n", "n for power"),
    ("note", "note"),
)


def _g(v: float) -> str:
    if isinstance(v, float) and math.isnan(v):
        return "-"
    return f"{v:.3g}"


def _cells(e: Effect) -> list[str]:
    return [
        e.source,
        e.task,
        e.metric,
        e.condition,
        str(e.n),
        f"{_g(e.mean_reference)} ({_g(e.sd_reference)})",
        f"{_g(e.mean_condition)} ({_g(e.sd_condition)})",
        f"{_g(e.difference)} [{_g(e.difference_low)}, {_g(e.difference_high)}]",
        f"{_g(e.cohens_dz)} [{_g(e.dz_low)}, {_g(e.dz_high)}]",
        f"{_g(e.mixedlm_coef)} [{_g(e.mixedlm_low)}, {_g(e.mixedlm_high)}], p={_g(e.mixedlm_p)}",
        _g(e.power_n) if not math.isnan(e.power_n) else "&gt; max_n",
        e.note,
    ]


def figure(group: Any, conditions: list[str], reference: str, title: str, power: Any = None, seed: int = 0) -> str:
    """Per-participant means by condition (dots, box), the paired differences and, given the
    study's power settings, the simulated power against the number of participants: a base64 PNG."""
    matplotlib = require("study", "matplotlib", "the study report")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = group.groupby(["participant", "condition"])["value"].mean().unstack("condition")
    present = [c for c in conditions if c in cells.columns]
    fig, axes = plt.subplots(1, 3 if power is not None else 2, figsize=(13 if power is not None else 9, 3.2), dpi=90)
    left, right = axes[0], axes[1]
    rng = np.random.default_rng(0)
    data = [cells[c].dropna().to_numpy(float) for c in present]
    left.boxplot(data, showfliers=False)
    left.set_xticks(range(1, len(present) + 1), present)
    for k, values in enumerate(data):
        left.scatter(k + 1 + rng.uniform(-0.15, 0.15, len(values)), values, s=6, alpha=0.5)
    left.set_ylabel("participant mean")
    left.set_title(title, fontsize=9)
    for c in present:
        if c == reference or reference not in present:  # (a metric the reference condition never gave a finite value of)
            continue
        both = cells[[reference, c]].dropna()
        right.hist((both[c] - both[reference]).to_numpy(float), bins=20, alpha=0.6, label=f"{c} - {reference}")
    right.axvline(0.0, color="k", lw=0.8)
    right.set_xlabel("paired difference")
    if len(present) > 1:
        right.legend(fontsize=7)
    if power is not None:
        _power_panel(axes[2], cells, present, reference, power, seed)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _power_panel(ax: Any, cells: Any, present: list[str], reference: str, power: Any, seed: int) -> None:
    """Simulated power (the summary's method) at n = 2 .. max_n on a log grid, per condition."""
    ns = np.unique(np.geomspace(2, power.max_n, 12).astype(int))
    for c in present:
        if c == reference or reference not in present:
            continue
        both = cells[[reference, c]].dropna()
        diff = (both[c] - both[reference]).to_numpy(float)
        if len(diff) < 2:
            continue
        ax.plot(ns, [power_at(diff, int(n), power.alpha, power.simulations, seed) for n in ns], marker=".", label=c)
    ax.axhline(power.target, color="k", lw=0.8, ls="--")
    ax.set_xscale("log")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("participants")
    ax.set_ylabel(f"power (alpha {power.alpha})")


def write_report(path: Path, study: Any, table: Any, effects: list[Effect], runtime_s: float | None) -> Path:
    conditions = [c.name for c in study.conditions]
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(study.name)}</title>",
        "<style>body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse;font-size:12px}"
        "td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}</style></head><body>",
        f"<h1>{html.escape(study.name)}</h1>",
        "<p>",
        f"{table['participant'].nunique()} participants ({', '.join(sorted(table['source'].unique()))}), "
        f"conditions {', '.join(map(html.escape, conditions))} (reference {html.escape(study.reference)}), "
        f"tasks {', '.join(html.escape(t.name) for t in study.tasks)}, {study.repetitions} repetition(s), seed {study.seed}.",
        f" Power: participants for {study.power.target:.0%} power at alpha {study.power.alpha} "
        f"({study.power.simulations} simulated studies per n, up to {study.power.max_n}).",
        f" Run time {runtime_s:.1f} s." if runtime_s is not None else "",
        "</p><h2>Effects</h2><table><tr>",
        "".join(f"<th>{h}</th>" for _, h in EFFECT_COLUMNS),
        "</tr>",
    ]
    for e in effects:
        parts.append("<tr>" + "".join(f"<td>{html.escape(c) if '&gt;' not in c else c}</td>" for c in _cells(e)) + "</tr>")
    parts.append("</table><h2>Metrics</h2>")
    finite = table[np.isfinite(table["value"].to_numpy(float))]
    for (source, task, metric), group in finite.groupby(["source", "task", "metric"], sort=False):
        title = f"{task}: {metric} ({source})"
        png = figure(group, conditions, study.reference, title, study.power, study.seed)
        parts.append(f"<h3>{html.escape(title)}</h3><img alt='{html.escape(title)}' src='data:image/png;base64,{png}'>")
    parts.append("</body></html>")
    path.write_text("\n".join(parts), encoding="utf-8")
    return path
