"""Plots and figures of `opends-gym conform` on the real OpenDS drives, for the docs.

Why: docs/vehicle-conformance.md shows recorded against simulated speed and path for every
real drive longer than 20 s on both backends; this script makes those PNGs (into
docs/images/conformance/) and prints the figures table, so both can be regenerated:

    PYTHONPATH=. python scripts/conform_plots.py
"""

from __future__ import annotations

import logging
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from opends_gym.record.cardata import read_cardata
from opends_gym.record.conform import MIN_DURATION_S, Recorded, conform

ROOT = Path(__file__).resolve().parent.parent
DRIVES = ROOT / "tests" / "data" / "opends-drives"
OUT = ROOT / "docs" / "images" / "conformance"
KEYS = ("windows", "median_speed_err_kmh", "median_heading_err_deg", "median_pos_err_m", "rms_speed_err_kmh")


def _trace(path: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names or ()}


def main() -> int:
    logging.disable(logging.WARNING)
    OUT.mkdir(parents=True, exist_ok=True)
    logs = sorted(p for p in DRIVES.glob("drives/*/carData*.txt") if read_cardata(p).t_s()[-1] > MIN_DURATION_S)
    print("| drive | backend | " + " | ".join(KEYS) + " | passed |")
    print("|---|---|" + "---|" * (len(KEYS) + 1))
    for log in logs:
        rec = Recorded(log)
        name = f"{log.parent.name}_{log.stem}".replace("(", "").replace(")", "")
        runs = {}
        with tempfile.TemporaryDirectory() as tmp:
            for physics in ("fast", "bullet"):
                trace = Path(tmp) / f"{physics}.csv"
                r = conform(log, DRIVES / "Countryside", physics=physics, trace=trace)
                runs[physics] = _trace(trace)
                cells = " | ".join(str(r[k]) for k in KEYS)
                print(f"| {log.parent.name}/{log.name} | {physics} | {cells} | {r['passed']} |")
        fig, (ax_v, ax_p) = plt.subplots(1, 2, figsize=(12, 4.5))
        ax_v.plot(rec.t, rec.speed_kmh, "k-", lw=2, label="OpenDS (recorded)")
        ax_p.plot(rec.x, rec.z, "k-", lw=2, label="OpenDS (recorded)")
        for physics, style in (("fast", "C0--"), ("bullet", "C1:")):
            tr = runs[physics]
            ax_v.plot(tr["t_s"], tr["speed_kmh"], style, lw=1.5, label=f"{physics} (open loop)")
            ax_p.plot(tr["x_m"], tr["z_m"], style, lw=1.5, label=f"{physics} (open loop)")
        ax_v.set(xlabel="time (s)", ylabel="speed (km/h)", title=f"speed: {log.parent.name}/{log.name}")
        ax_p.set(xlabel="x (m)", ylabel="z (m)", title="path (whole run, open loop)")
        ax_p.set_aspect("equal", adjustable="datalim")
        for ax in (ax_v, ax_p):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(OUT / f"{name}.png", dpi=90)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
