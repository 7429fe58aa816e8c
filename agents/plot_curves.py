"""Plot the shipped policies' training curves into one PNG for the README.

Each run folder written by `opends-gym train` holds `curve.csv` (env steps, mean return of
the last 10 training episodes) and `evaluations.npz` (deterministic evaluation returns at
each evaluation); both are drawn per policy, one panel each.

    python agents/plot_curves.py [--policies agents/policies] [--out agents/policies/training_curves.png]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

POLICIES = Path(__file__).resolve().parent / "policies"


def read_curve(run: Path) -> tuple[np.ndarray, np.ndarray]:
    """(env steps, mean training return) from a run folder's curve.csv."""
    with (run / "curve.csv").open(newline="") as f:
        rows = [(int(r["steps"]), float(r["mean_return_last_10"])) for r in csv.DictReader(f)]
    if not rows:
        raise ValueError(f"{run / 'curve.csv'}: no rows")
    steps, returns = zip(*rows, strict=True)
    return np.asarray(steps), np.asarray(returns)


def read_evaluations(run: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """(env steps, mean evaluation return) from evaluations.npz, or None when there is none."""
    path = run / "evaluations.npz"
    if not path.is_file():
        return None
    with np.load(path) as d:
        return np.asarray(d["timesteps"]), np.asarray(d["results"]).mean(axis=1)


def plot(runs: list[Path], out: Path) -> Path:
    """One panel per run folder; returns the written PNG's path."""
    if not runs:
        raise ValueError("no run folders with a curve.csv")
    fig, axes = plt.subplots(1, len(runs), figsize=(4.2 * len(runs), 3.2), squeeze=False)
    for ax, run in zip(axes[0], runs, strict=True):
        steps, returns = read_curve(run)
        ax.plot(steps / 1e3, returns, label="training (mean of last 10 episodes)")
        ev = read_evaluations(run)
        if ev is not None:
            ax.plot(ev[0] / 1e3, ev[1], "o-", label="deterministic evaluation")
        ax.set_title(run.name)
        ax.set_xlabel("env steps (thousands)")
        ax.set_ylabel("episode return")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--policies", type=Path, default=POLICIES, help="folder of run folders")
    p.add_argument("--out", type=Path, default=POLICIES / "training_curves.png")
    args = p.parse_args(argv)
    runs = sorted(d for d in args.policies.iterdir() if (d / "curve.csv").is_file())
    print(plot(runs, args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
