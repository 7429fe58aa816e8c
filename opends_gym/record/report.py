"""The analyzer's report: a multi-page PDF (and a PNG per page) a paper can use.

Pages, in order:
1. **summary** -- what was driven (task, env, seed, source file) and the measures table;
2. **reactions** (when trials were scored) -- reaction time per trial, bars coloured by the
   task's reaction groups (settings.xml `reactionMeasurement` groupRed ... groupMagenta, as
   OpenDS's `reactionReport.pdf`), failures hatched, misses marked at the top, mean per group;
3. **path** -- the driven path over the ideal track(s) with OpenDS's red deviation lines
   (lane tasks are drawn along the road: distance vs lateral position, in rows);
4. **time series** -- speed, pedals and steering over time with the task's events marked.

matplotlib with the Agg backend (no display) and `PdfPages`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..extras import MissingExtra

try:
    import matplotlib
except ImportError as e:  # the `report` extra: one line naming the pip command
    raise MissingExtra("report", "matplotlib", "the analyzer's PDF report") from e

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from .analyze import Analysis
from .drive import locate_many

A4_LANDSCAPE = (11.69, 8.27)
GROUP_COLOURS = {"red": "#d62728", "green": "#2ca02c", "yellow": "#e6b800", "cyan": "#17becf", "blue": "#1f77b4", "magenta": "#c2185b"}
FALLBACK = ["#7f7f7f", "#8c564b", "#9467bd", "#bcbd22", "#ff7f0e", "#aec7e8"]
ROWS_PER_PATH_PAGE = 4


def group_colours(a: Analysis) -> dict[str, str]:
    """Reaction group -> colour, from the task's settings (unknown groups get neutral tones)."""
    configured = a.drive.analysis.get("reaction_groups") or {}
    out: dict[str, str] = {}
    spare = iter(FALLBACK * 4)
    for r in a.drive.reactions:
        g = str(r.get("group", ""))
        if g not in out:
            out[g] = GROUP_COLOURS.get(configured.get(g, ""), "") or next(spare)
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "n/a"
        if math.isinf(v):
            return "none" if v > 0 else "-inf"
        return f"{v:.4g}" if abs(v) < 1e5 else f"{v:.0f}"
    return str(v)


def _title_lines(a: Analysis) -> list[str]:
    d = a.drive
    m = d.meta
    what = m.get("task_name") or m.get("driving_task") or "?"
    lines = [
        f"Drive analysis: {what}",
        f"recording: {d.path.name} ({'OpenDS carData.txt, ' + str(m.get('cardata_variant')) if d.source == 'cardata' else 'MCAP'})",
    ]
    if m.get("env_id"):
        kw = m.get("env_kwargs") or {}
        phys = kw.get("physics", "fast")
        lines.append(f"env: {m['env_id']}  seed {m.get('seed')}  physics {phys}  software {m.get('software_version', '')}")
    elif d.source == "cardata":
        lines.append(f"driver: {m.get('driver') or '?'}  created: {m.get('created') or '?'}")
    for note in d.notes:
        lines.append(f"note: {note}")
    return lines


# ------------------------------------------------------------------ pages
def summary_page(a: Analysis) -> Figure:
    fig = plt.figure(figsize=A4_LANDSCAPE)
    lines = _title_lines(a)
    fig.text(0.04, 0.95, lines[0], fontsize=16, weight="bold", va="top")
    for k, line in enumerate(lines[1:]):
        fig.text(0.04, 0.91 - 0.025 * k, line, fontsize=9, va="top", family="monospace")
    rows = [(sec, name, _fmt(v), unit) for sec, name, v, unit in a.rows()]
    half = (len(rows) + 1) // 2
    top = 0.86 - 0.025 * max(0, len(lines) - 1)
    for col, chunk in enumerate((rows[:half], rows[half:])):
        if not chunk:
            continue
        ax = fig.add_axes((0.03 + 0.49 * col, 0.04, 0.46, top - 0.06))
        ax.axis("off")
        table = ax.table(
            cellText=[list(r) for r in chunk], colLabels=["section", "measure", "value", "unit"], loc="upper center", cellLoc="left"
        )
        table.auto_set_font_size(False)
        table.set_fontsize(7.5)
        table.scale(1.0, 1.05)
        for (r, _), cell in table.get_celld().items():
            if r == 0:
                cell.set_text_props(weight="bold")
    return fig


def reactions_page(a: Analysis) -> Figure:
    reactions = a.drive.reactions
    colours = group_colours(a)
    fig, (ax, ax_t) = plt.subplots(2, 1, figsize=A4_LANDSCAPE, gridspec_kw={"height_ratios": [3, 1]})
    rts = [float(r["reaction_time_s"]) for r in reactions if int(r["result"]) != -2]
    top = max([1.0, *rts]) * 1.4  # headroom for the legend
    idx = np.arange(1, len(reactions) + 1)
    for i, r in zip(idx, reactions):
        g = str(r.get("group", ""))
        res = int(r["result"])
        c = colours[g]
        if res == 1:
            ax.bar(i, float(r["reaction_time_s"]), color=c, edgecolor="black", linewidth=0.5)
        elif res == -1:
            ax.bar(i, float(r["reaction_time_s"]), color="white", edgecolor=c, hatch="xx", linewidth=1.0)
            ax.text(i, float(r["reaction_time_s"]), "fail", ha="center", va="bottom", fontsize=7)
        else:
            ax.bar(i, top, color="white", edgecolor=c, hatch="//", linewidth=1.0, alpha=0.8)
            ax.text(i, top * 0.98, "miss", ha="center", va="top", fontsize=7, rotation=90)
    for g, c in colours.items():
        stats = a.groups.get(g, {})
        m = stats.get("mean_rt_s", math.nan)
        if isinstance(m, float) and math.isfinite(m):
            ax.axhline(m, color=c, linestyle="--", linewidth=1.0)
    handles = [Patch(facecolor=c, edgecolor="black", label=g or "(no group)") for g, c in colours.items()]
    handles += [
        Patch(facecolor="white", edgecolor="black", hatch="xx", label="failure"),
        Patch(facecolor="white", edgecolor="black", hatch="//", label="missed"),
    ]
    ax.legend(handles=handles, loc="upper left", fontsize=8, ncol=min(4, len(handles)))
    ax.set_ylim(0, top)
    ax.set_xlim(0.3, len(reactions) + 0.7)
    ax.set_xticks(idx)
    ax.set_xlabel("trial")
    ax.set_ylabel("reaction time (s)")
    ax.set_title("Reaction times by trial (dashed: group mean of correct reactions)")
    ax_t.axis("off")
    rows = [
        [
            g,
            _fmt(s["trials"]),
            _fmt(s["correct"]),
            _fmt(s["failures"]),
            _fmt(s["misses"]),
            _fmt(s["hit_rate"]),
            _fmt(s["mean_rt_s"]),
            _fmt(s["sd_rt_s"]),
        ]
        for g, s in a.groups.items()
    ]
    t = ax_t.table(
        cellText=rows, colLabels=["group", "trials", "correct", "failures", "misses", "hit rate", "mean RT (s)", "SD RT (s)"], loc="center"
    )
    t.auto_set_font_size(False)
    t.set_fontsize(8)
    for (r, c), cell in t.get_celld().items():
        if r > 0 and c == 0 and rows[r - 1][0] in colours:
            cell.set_facecolor(colours[rows[r - 1][0]])
            cell.set_alpha(0.35)
    fig.tight_layout()
    return fig


def path_pages(a: Analysis) -> list[Figure]:
    d = a.drive
    guide = d.analysis.get("guide") or {}
    if guide.get("kind") == "lanes":
        return _road_path_pages(a, guide)
    panels = 2 if a.deviations else 1
    fig, axes = plt.subplots(1, panels, figsize=A4_LANDSCAPE, squeeze=False)
    for k, ax in enumerate(axes[0]):
        for tr in a.deviations:
            label = f"ideal track {tr.track_id} ({_fmt(tr.result.mean_deviation_m)} m, {tr.result.status})"
            ax.plot(tr.ideal[:, 0], tr.ideal[:, 1], "-", color="0.3", linewidth=1.2, label=label)
            for ip, dp in zip(tr.ideal, tr.result.driven_points):
                if dp is not None:
                    ax.plot([ip[0], dp[0]], [ip[1], dp[1]], "-", color="red", linewidth=0.8)
        ax.plot(d.col("x_m"), d.col("z_m"), "-", color="#1f77b4", linewidth=1.0, label="driven path")
        ax.plot(d.col("x_m")[:1], d.col("z_m")[:1], "o", color="#1f77b4")
        if k == 1:  # zoom on the ideal tracks
            pts = np.vstack([tr.ideal for tr in a.deviations])
            pad = 15.0
            ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
            ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
            ax.set_title("ideal track(s), red: deviation lines (OpenDS Drive Analyzer)", fontsize=10)
        else:
            ax.set_title("whole drive" if panels == 2 else "Driven path (no ideal track in this task)", fontsize=10)
            ax.legend(fontsize=8, loc="best")
        ax.set_aspect("equal", adjustable="datalim" if k == 0 else "box")
        ax.invert_yaxis()  # seen from above: X to the right, -Z (OpenDS's forward) up
        ax.set_xlabel("world X (m)")
        ax.set_ylabel("world Z (m)")
    fig.suptitle("Driven path")
    fig.tight_layout()
    return [fig]


def _road_path_pages(a: Analysis, guide: dict[str, Any]) -> list[Figure]:
    """Lane tasks are long and narrow: draw distance along the road vs lateral position."""
    d = a.drive
    s, lat = d.col("s_m"), d.col("lateral_m")
    lo, hi = float(np.nanmin(s)), float(np.nanmax(s))
    lanes = d.analysis.get("lanes") or []
    sign = float(guide.get("sign", 1.0))
    rows = max(1, min(ROWS_PER_PATH_PAGE * 3, int(math.ceil((hi - lo) / 800.0))))
    edges = np.linspace(lo, hi, rows + 1)
    tracks = []
    for tr in a.deviations:
        ts, tl, _, _ = locate_many(guide, tr.ideal[:, 0], tr.ideal[:, 1])
        dps = [None if p is None else locate_many(guide, np.array([p[0]]), np.array([p[1]])) for p in tr.result.driven_points]
        tracks.append((tr, ts, tl, dps))
    figs = []
    for page_start in range(0, rows, ROWS_PER_PATH_PAGE):
        n = min(ROWS_PER_PATH_PAGE, rows - page_start)
        fig, axes = plt.subplots(n, 1, figsize=A4_LANDSCAPE, squeeze=False)
        for k in range(n):
            ax = axes[k, 0]
            a0, a1 = edges[page_start + k], edges[page_start + k + 1]
            for j, band in enumerate(lanes):
                y0, y1 = sorted((-sign * band["x_min_m"], -sign * band["x_max_m"]))
                ax.axhspan(y0, y1, color="0.95" if j % 2 else "0.88", zorder=0)
                ax.axhline(y0, color="0.6", linewidth=0.5, linestyle="--")
                ax.axhline(y1, color="0.6", linewidth=0.5, linestyle="--")
            for tr, ts, tl, dps in tracks:
                ax.plot(
                    ts,
                    tl,
                    "-",
                    color="0.25",
                    linewidth=1.0,
                    label=f"{tr.track_id}: {_fmt(tr.result.mean_deviation_m)} m ({tr.result.status})",
                )
                for is_, il, dp in zip(ts, tl, dps):
                    if dp is not None and a0 <= is_ <= a1:
                        ax.plot([is_, dp[0][0]], [il, dp[1][0]], "-", color="red", linewidth=0.7)
            m = (s >= a0) & (s <= a1)
            ax.plot(s[m], lat[m], "-", color="#1f77b4", linewidth=1.0, label="driven")
            ax.set_xlim(a0, a1)
            ax.set_ylabel("lateral (m, + left)")
            if k == 0:
                ax.legend(fontsize=7, loc="upper right")
        axes[-1, 0].set_xlabel("distance along the road (m)")
        fig.suptitle("Driven path over the ideal track (red: OpenDS deviation lines)" if a.deviations else "Driven path on the lanes")
        fig.tight_layout()
        figs.append(fig)
    return figs


_EVENT_STYLE = {"reaction_timer": ("0.5", "--"), "collision": ("red", "-"), "recording": ("green", ":"), "log": ("0.4", ":")}


def timeseries_page(a: Analysis) -> Figure:
    d = a.drive
    t = d.col("t_s")
    fig, axes = plt.subplots(4, 1, figsize=A4_LANDSCAPE, sharex=True)
    axes[0].plot(t, d.col("speed_kmh"), color="#1f77b4")
    axes[0].set_ylabel("speed (km/h)")
    axes[1].plot(t, d.col("accelerator"), color="#2ca02c", label="accelerator")
    axes[1].plot(t, d.col("brake"), color="#d62728", label="brake")
    axes[1].set_ylabel("pedal (0..1)")
    axes[1].set_ylim(-0.05, 1.05)
    axes[1].legend(fontsize=7, loc="upper right")
    axes[2].plot(t, d.col("steering"), color="#9467bd")
    axes[2].set_ylabel("steering (-1..1, + left)")
    axes[3].plot(t, d.col("lane_offset_m"), color="#8c564b")
    axes[3].set_ylabel("lane offset (m)")
    axes[3].set_xlabel("time (s)")
    colours = group_colours(a)
    for e in d.events:
        style = _EVENT_STYLE.get(str(e.get("kind")))
        if style is not None:
            for ax in axes:
                ax.axvline(float(e["t_s"]), color=style[0], linestyle=style[1], linewidth=0.6)
    for r in d.reactions:
        mark = {1: "o", -1: "x", -2: "s"}.get(int(r["result"]), ".")
        axes[0].plot(
            float(r["t_s"]),
            np.interp(float(r["t_s"]), t, d.col("speed_kmh")),
            mark,
            color=colours.get(str(r.get("group", "")), "k"),
            markersize=6,
        )
    fig.suptitle("Speed, pedals and steering over time (dashed: reaction timer armed; markers: trial scored o correct x failure [] miss)")
    fig.tight_layout()
    return fig


Percentiles = tuple[str, list[tuple[str, float, float, int, float]]]  # reference, (metric, value, percentile %, n, median)


def percentiles_page(a: Analysis, percentiles: Percentiles) -> Figure:
    """The drive's metrics with their percentile among a reference population (`analyze --against`)."""
    label, rows = percentiles
    fig = plt.figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.95, "Against the virtual population", fontsize=16, weight="bold", va="top")
    fig.text(0.04, 0.91, label, fontsize=9, va="top", family="monospace")
    ax = fig.add_axes((0.05, 0.06, 0.9, 0.8))
    ax.axis("off")
    cells = [[m, _fmt(v), _fmt(p), _fmt(med), str(n)] for m, v, p, n, med in rows]
    table = ax.table(
        cellText=cells,
        colLabels=["metric", "drive", "percentile %", "population median", "participants"],
        loc="upper center",
        cellLoc="left",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    for (r, _), cell in table.get_celld().items():
        if r == 0:
            cell.set_text_props(weight="bold")
    return fig


def write_report(a: Analysis, pdf_path: str | Path, png: bool = True, percentiles: Percentiles | None = None) -> list[str]:
    """Write the PDF (and `<stem>_<n>_<page>.png` beside it); returns the page names in order.
    `percentiles` (from `analyze --against`) adds a page after the summary."""
    out = Path(pdf_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    pages: list[tuple[str, Figure]] = [("summary", summary_page(a))]
    if percentiles is not None:
        pages.append(("percentiles", percentiles_page(a, percentiles)))
    if a.drive.reactions:
        pages.append(("reactions", reactions_page(a)))
    pages += [("path" if k == 0 else f"path{k + 1}", f) for k, f in enumerate(path_pages(a))]
    pages.append(("timeseries", timeseries_page(a)))
    info = {"Title": _title_lines(a)[0], "Creator": "opends_gym analyze", "Subject": str(a.drive.path.name)}
    with PdfPages(out, metadata=info) as pdf:
        for k, (name, fig) in enumerate(pages, start=1):
            pdf.savefig(fig)
            if png:
                fig.savefig(out.with_name(f"{out.stem}_{k}_{name}.png"), dpi=110)
            plt.close(fig)
    return [name for name, _ in pages]
