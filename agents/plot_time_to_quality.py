"""Plot time to quality: each run's evaluations against the wall time its training took.

`opends-gym train` on the native batch (`vec_env: native`) writes `curve.csv` with the wall
seconds of training (`train_s`, evaluations excluded) and, at each evaluation, the
evaluation episode's metrics (`eval_*`). This draws, per run folder, the evaluation return
over training minutes, and the quality metric of its test (LCT: correct lane changes of
18 and MDEV; brake: brake signs obeyed, missed stimuli and collisions; platoon: stimuli
reached, missed and collisions), marking where the run met its config's `stop_at` bar
(`metrics.json` `stopped_at`). A run warm-started by cloning a driver (`warm_start:`) has a
first evaluation at step 0: the clone, after the wall time the cloning took.

    python agents/plot_time_to_quality.py RUN_DIR [RUN_DIR ...] --out docs/images/time_to_quality.png
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

QUALITY = {  # the test's metrics, per env: (curve column, label)
    "OpenDS/LaneChangeTest-v0": [("eval_lane_changes_correct", "correct lane changes (of 18)"), ("eval_mdev_basic_m", "MDEV m")],
    "OpenDS/BrakeReaction-v0": [
        ("eval_BrakeSign_correct", "brake signs obeyed (of 3)"),
        ("eval_stimulus_misses", "missed stimuli"),
        ("eval_collisions", "collisions"),
    ],
    "OpenDS/ThreeVehiclePlatoon-v0": [
        ("eval_stimuli", "stimuli reached (of 10)"),
        ("eval_stimulus_misses", "missed stimuli"),
        ("eval_collisions", "collisions"),
        ("eval_longitudinal_deviation_mean_m", "band deviation m (mean)"),
    ],
}


def read(run: Path) -> tuple[list[dict[str, float]], dict[str, object]]:
    """(the rows of curve.csv that hold an evaluation, metrics.json)."""
    path = run / "curve.csv"
    with path.open(newline="", encoding="utf-8") as f:
        rows = [{k: float(v) if v not in ("", None) else math.nan for k, v in r.items()} for r in csv.DictReader(f)]
    evaluated = [r for r in rows if math.isfinite(r.get("eval_return", math.nan))]
    if "train_s" not in (rows[0] if rows else {}) or not evaluated:
        raise ValueError(f"{path}: no evaluations with train_s (a native-batch run's curve is needed)")
    return evaluated, json.loads((run / "metrics.json").read_text(encoding="utf-8"))


def plot(runs: list[Path], out: Path) -> Path:
    fig, axes = plt.subplots(1, len(runs), figsize=(4.4 * len(runs), 3.3), squeeze=False)
    for ax, run in zip(axes[0], runs, strict=True):
        rows, metrics = read(run)
        minutes = [r["train_s"] / 60 for r in rows]
        ax.plot(minutes, [r["eval_return"] for r in rows], "o-", color="tab:blue", label="evaluation return")
        ax.set_xlabel("training wall time (min)")
        ax.set_xlim(left=0)
        ax.set_ylabel("episode return", color="tab:blue")
        ax.set_ylim(bottom=min(0.0, *(r["eval_return"] for r in rows)), top=max(1.0, *(r["eval_return"] for r in rows)) * 1.05)
        twin = ax.twinx()
        styles = (("s--", "tab:orange"), ("^:", "tab:green"), ("v-.", "tab:red"), ("D--", "tab:purple"))
        for (column, label), (style, color) in zip(QUALITY.get(str(metrics.get("env")), []), styles, strict=False):
            twin.plot(minutes, [r.get(column, math.nan) for r in rows], style, color=color, label=label)
        twin.legend(fontsize=7, loc="center right")
        stopped = metrics.get("stopped_at")
        title = run.name + (f": bar met at {rows[-1]['train_s'] / 60:.1f} min" if stopped else "")
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", type=Path, help="run folders written by opends-gym train (vec_env: native)")
    p.add_argument("--out", type=Path, default=Path("time_to_quality.png"))
    args = p.parse_args()
    try:
        print(plot(args.runs, args.out))
    except (OSError, ValueError) as e:
        raise SystemExit(f"plot_time_to_quality: {e}") from None


if __name__ == "__main__":
    main()
