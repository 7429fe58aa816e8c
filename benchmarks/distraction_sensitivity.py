"""Do the distraction metrics separate attentive from distracted driving?

For each distraction level of `opends_gym.drivers.distracted` (none, light, moderate,
heavy), N seeded episodes of the lane change test (with an ISO 17488 DRT), the brake
reaction test and the three-vehicle platoon test are driven by the distracted rule
driver. The script prints one table (mean and 95 % CI per metric and level), says which
metrics rise monotonically with the level, compares the magnitudes with published human
values, and writes a plot.

    python benchmarks/distraction_sensitivity.py [--episodes 5] [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.drivers.distracted import LEVEL_ORDER, DistractedDriver
from opends_gym.drivers.episodes import run_episode
from opends_gym.envs.drt import DetectionResponseTask
from opends_gym.metrics.stats import mean_ci


@dataclass(frozen=True)
class Metric:
    env: str
    key: str
    label: str
    human: str  # published human magnitude, with its source


METRICS = (
    Metric(
        "lct", "mdev_basic_m", "LCT MDEV (basic model), m", "baseline ~1 m, rising with visual-manual tasks (Mattes 2003; SAE 2023-01-0791)"
    ),
    Metric("lct", "sdlp_m", "LCT SDLP (lane keeping), m", "0.2-0.3 m in simulators, > +0.024 m counts as impairment (Verster & Roth 2014)"),
    Metric(
        "lct",
        "steering_reversal_rate_per_min",
        "steering reversals (2 deg gap), 1/min",
        "rises with visual load at large gaps (Markkula & Engström 2006)",
    ),
    Metric(
        "lct",
        "drt_mean_rt_s",
        "DRT reaction time, s",
        "a few hundred ms at baseline, longer under load (ISO 17488; Stojmenova & Sodnik 2018)",
    ),
    Metric("lct", "drt_hit_rate", "DRT hit rate", "~0.9-1.0 at baseline, falling under load (ISO 17488)"),
    Metric("brake", "brake_onset_s", "brake RT to lead-car stimuli, s", "0.7 s expected to 1.5 s surprise events (Green 2000)"),
    Metric("brake", "BrakeSign_mean_rt_s", "brake-sign reaction time (OpenDS timer), s", "OpenDS timer: time to reach the target speed"),
    Metric("platoon", "longitudinal_deviation_mean_m", "TVPT longitudinal deviation, m", "outside the 20-35 m band (OpenDS TVPT)"),
    Metric("platoon", "lateral_deviation_mean_m", "TVPT lateral deviation, m", "outside the -2..3 m band (OpenDS TVPT)"),
    Metric("platoon", "stimulus_mean_rt_s", "TVPT stimulus reaction time, s", "within maxReactionTime 5 s (OpenDS TVPT)"),
)

ENVS: dict[str, Callable[[], gym.Env[Any, Any]]] = {
    "lct": lambda: DetectionResponseTask(gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons")),
    "brake": lambda: gym.make("OpenDS/BrakeReaction-v0"),
    "platoon": lambda: gym.make("OpenDS/ThreeVehiclePlatoon-v0"),
}


def collect(episodes: int, seed: int) -> dict[tuple[str, str], list[dict[str, float]]]:
    results: dict[tuple[str, str], list[dict[str, float]]] = {}
    for env_name, make in ENVS.items():
        env = make()
        for level in LEVEL_ORDER:
            results[(env_name, level)] = [run_episode(env, DistractedDriver(level), seed + k).metrics for k in range(episodes)]
            print(f"  {env_name:8s} {level:9s} done", file=sys.stderr)
        env.close()
    return results


def table(results: dict[tuple[str, str], list[dict[str, float]]]) -> list[tuple[Metric, list[Any], bool]]:
    rows = []
    for m in METRICS:
        cis = [mean_ci(float(e.get(m.key, math.nan)) for e in results[(m.env, level)]) for level in LEVEL_ORDER]
        means = [c.mean for c in cis]
        falling = m.key == "drt_hit_rate"
        finite = [v for v in means if math.isfinite(v)]
        pairs = list(itertools.pairwise(finite))
        monotonic = len(finite) == len(means) and all((b <= a) if falling else (b >= a) for a, b in pairs)
        rows.append((m, cis, monotonic))
    return rows


def print_table(rows: list[tuple[Metric, list[Any], bool]], episodes: int) -> None:
    print(f"distraction sensitivity: {episodes} seeded episodes per level, mean [95% CI]")
    head = f"{'metric':44s}" + "".join(f"{lvl:>24s}" for lvl in LEVEL_ORDER) + "  monotonic"
    print(head)
    print("-" * len(head))
    for m, cis, mono in rows:
        cells = "".join(f"{_fmt(c.mean):>8s} [{_fmt(c.low)}, {_fmt(c.high)}]".rjust(24) for c in cis)
        print(f"{m.label:44s}{cells}  {'yes' if mono else 'no'}")
    print()
    print("published human magnitudes for comparison:")
    for m, _, _ in rows:
        print(f"  {m.label}: {m.human}")


def _fmt(v: float) -> str:
    return "nan" if not math.isfinite(v) else f"{v:.3g}"


def plot(rows: list[tuple[Metric, list[Any], bool]], out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(rows)
    cols = 4
    fig, axes = plt.subplots(math.ceil(n / cols), cols, figsize=(4 * cols, 3 * math.ceil(n / cols)), squeeze=False)
    x = np.arange(len(LEVEL_ORDER))
    for ax, (m, cis, mono) in zip(axes.flat, rows):
        means = np.array([c.mean for c in cis])
        lo = np.array([c.low for c in cis])
        hi = np.array([c.high for c in cis])
        ax.errorbar(x, means, yerr=[np.nan_to_num(means - lo), np.nan_to_num(hi - means)], marker="o", capsize=3)
        ax.set_xticks(x, LEVEL_ORDER)
        ax.set_title(m.label + ("" if mono else " (not monotonic)"), fontsize=8)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    path = out / "distraction_sensitivity.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=5)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = p.parse_args(argv)
    rows = table(collect(args.episodes, args.seed))
    print_table(rows, args.episodes)
    print(f"\nplot: {plot(rows, Path(args.out))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
