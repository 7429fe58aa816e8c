"""Score the baseline drivers side by side: rule, distracted (heavy) and the shipped policies.

Every driver runs the same seeded episodes of each test through the same agent interface
as `opends-gym run`, and the table shows each test's headline metrics (mean over episodes).

    python agents/evaluate.py [--episodes 3] [--markdown]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.drivers.agents import make_agent
from opends_gym.drivers.episodes import run_episode
from opends_gym.metrics.stats import mean_ci

POLICIES = Path(__file__).resolve().parent / "policies"

# (env id, the headline metrics); every shipped policy trained on the env joins the rule drivers
TESTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("OpenDS/LaneChangeTest-v0", ("mdev_basic_m", "mdev_adapted_m", "lane_changes_correct", "sdlp_m")),
    ("OpenDS/BrakeReaction-v0", ("stimulus_misses", "brake_onset_s", "BrakeSign_correct", "collisions")),
    (
        "OpenDS/ThreeVehiclePlatoon-v0",
        ("stimulus_misses", "stimulus_mean_rt_s", "longitudinal_deviation_mean_m", "lateral_deviation_mean_m"),
    ),
)


def shipped_policies(env_id: str) -> list[tuple[str, str]]:
    """(agent spec, label) of each policy folder whose metrics.json names this env."""
    out = []
    for folder in sorted(POLICIES.iterdir()) if POLICIES.is_dir() else ():
        meta = folder / "metrics.json"
        if (folder / "model.zip").is_file() and meta.is_file():
            info = json.loads(meta.read_text(encoding="utf-8"))
            if info.get("env") == env_id:
                algorithm = str(info.get("algorithm", "ppo"))
                out.append((f"{algorithm}:{folder / 'model.zip'}", f"{algorithm} ({folder.name})"))
    return out


def run(env_id: str, agent_spec: str, episodes: int, seed: int) -> dict[str, float]:
    env = gym.make(env_id)
    rows: list[dict[str, Any]] = []
    try:
        for k in range(episodes):
            agent = make_agent(agent_spec)
            ep = run_episode(env, agent, seed + k)
            rows.append({"return": ep.ret, **ep.metrics})
    finally:
        env.close()
    return {key: mean_ci(float(r[key]) for r in rows).mean for key in rows[0] if isinstance(rows[0][key], (int, float))}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("--markdown", action="store_true", help="print Markdown tables (for the README)")
    args = p.parse_args(argv)
    for env_id, keys in TESTS:
        policies = shipped_policies(env_id)
        if not policies:
            print(f"({env_id}: no shipped policy in {POLICIES})", file=sys.stderr)
        agents = ["rule", "distracted:heavy", *(spec for spec, _ in policies)]
        cols = ("return", *keys)
        results = {a: run(env_id, a, args.episodes, args.seed) for a in agents}
        label = {a: a for a in agents} | dict(policies)
        if args.markdown:
            print(f"\n**{env_id}** ({args.episodes} episodes, seeds {args.seed}..)\n")
            print("| driver | " + " | ".join(cols) + " |")
            print("|---" * (len(cols) + 1) + "|")
            for a in agents:
                print(f"| {label[a]} | " + " | ".join(_fmt(results[a].get(c, math.nan)) for c in cols) + " |")
        else:
            print(f"\n{env_id} ({args.episodes} episodes)")
            print("driver".ljust(22) + "".join(c.rjust(32) for c in cols))
            for a in agents:
                print(label[a].ljust(22) + "".join(_fmt(results[a].get(c, math.nan)).rjust(32) for c in cols))
    return 0


def _fmt(v: float) -> str:
    return "nan" if not math.isfinite(v) else f"{v:.3g}"


if __name__ == "__main__":
    raise SystemExit(main())
