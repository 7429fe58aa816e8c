"""A drive against a population: each metric with its percentile among virtual participants.

Why: a lab wants to know where a person stands among calibrated virtual drivers on the same task
and condition. The reference is either a study's long-format table (`opends-gym study` output:
its folder, table.csv or table.parquet; the `virtual` rows of one task and condition, each
participant's mean over trials) or `population:N[:LOAD]`: N participants of the standard
population (`participant:ID:LOAD`, IDs 0..N-1, seed = ID) simulated on the drive's env.

The percentile is the percentile rank of the drive's value among the participants' values,
scipy.stats.percentileofscore's kind="mean": (share below + share at or below) / 2, in %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UserError
from ..hints import did_you_mean

# analyzer row names -> the env's episode_metrics names they measure
ALIASES = {"reversal_rate_per_min": "steering_reversal_rate_per_min", "mean_abs_lane_offset_m": "mean_abs_lateral_offset_m"}
ANALYZER_SECTIONS = ("drive", "lane change test", "lateral control", "steering")


@dataclass(frozen=True)
class Placement:
    metric: str
    value: float
    percentile: float  # %, nan where the drive or the population has no value
    n: int  # participants with a value
    median: float  # the population's median


def percentile_rank(value: float, population: list[float]) -> float:
    """scipy.stats.percentileofscore(population, value, kind="mean"), without scipy."""
    pop = np.asarray([v for v in population if math.isfinite(v)], dtype=float)
    if not math.isfinite(value) or pop.size == 0:
        return math.nan
    return float(50.0 * (np.sum(pop < value) + np.sum(pop <= value)) / pop.size)


def drive_metrics(rows: list[tuple[str, str, Any, str]], episode_metrics: dict[str, float] | None = None) -> dict[str, float]:
    """The drive's metrics under the env's names: the analyzer's rows of its drive, LCT, lateral and
    steering sections, overlaid by the env's own episode_metrics where the drive was an env episode."""
    out: dict[str, float] = {}
    for section, name, value, _unit in rows:
        if section in ANALYZER_SECTIONS and isinstance(value, (int, float)) and not isinstance(value, bool):
            out[ALIASES.get(name, name)] = float(value)
    out.update(episode_metrics or {})
    return out


def _table_file(path: Path) -> Path:
    if path.is_dir():
        for name in ("table.parquet", "table.csv"):
            if (path / name).is_file():
                return path / name
        raise UserError(f"{path}: no table.parquet or table.csv (is it an opends-gym study output folder?)")
    return path


def study_population(spec: str, task: str | None, condition: str | None) -> tuple[dict[str, list[float]], str]:
    """metric -> per-participant means of the virtual rows of one task and condition of a study table."""
    from ..extras import require

    pd = require("study", "pandas", "reading a study table")
    path = _table_file(Path(spec))
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such study table or population spec (population:N[:LOAD])")
    frame = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    need = {"participant", "source", "condition", "task", "trial", "metric", "value"}
    if not need <= set(frame.columns):
        raise UserError(f"{path}: not a study table (columns {', '.join(map(str, frame.columns))}; need {', '.join(sorted(need))})")
    frame = frame[frame["source"] == "virtual"]
    picked = []
    for column, wanted, option in (("task", task, "--study-task"), ("condition", condition, "--condition")):
        values = sorted(map(str, frame[column].unique()))
        if wanted is None:
            wanted = "baseline" if column == "condition" and "baseline" in values else (values[0] if len(values) == 1 else None)
        if wanted not in values:
            hint = did_you_mean(wanted, values) if wanted else ""
            raise UserError(f"{path}: pick the {column} with {option} ({', '.join(values) or 'no virtual rows'}){hint}")
        frame = frame[frame[column].astype(str) == wanted]
        picked.append(wanted)
    means = frame.groupby(["metric", "participant"])["value"].mean()
    out: dict[str, list[float]] = {}
    for (metric, _participant), v in means.items():
        out.setdefault(str(metric), []).append(float(v))
    return out, f"{path} (virtual, task {picked[0]}, condition {picked[1]})"


def parse_population(spec: str) -> tuple[int, str]:
    """`population:N[:LOAD]` -> (N, LOAD)."""
    from ..drivers.population import LOADS

    _, _, rest = spec.partition(":")
    n_text, _, load = rest.partition(":")
    if not n_text.isdigit() or int(n_text) < 1:
        raise UserError(f"{spec!r}: give the population size: population:N[:LOAD], N >= 1")
    load = load or "baseline"
    if load not in LOADS:
        raise UserError(f"{spec!r}: unknown load {load!r}{did_you_mean(load, LOADS)}; use one of {', '.join(LOADS)}")
    return int(n_text), load


def simulated_population(spec: str, env_id: str, env_kwargs: dict[str, Any]) -> tuple[dict[str, list[float]], str]:
    """metric -> values of N virtual participants, each driving one episode of the env."""
    from ..drivers.agents import make_agent
    from ..drivers.episodes import run_episode
    from .episodes import make_env, scalar_metrics

    n, load = parse_population(spec)
    env = make_env(env_id, {**env_kwargs, "render_mode": None})
    out: dict[str, list[float]] = {}
    try:
        for ident in range(n):
            ep = run_episode(env, make_agent(f"participant:{ident}:{load}"), ident)
            for k, v in scalar_metrics(ep.metrics).items():
                out.setdefault(k, []).append(v)
    finally:
        env.close()
    return out, f"{n} virtual participants ({load}) on {env_id}"


def place(drive: dict[str, float], population: dict[str, list[float]]) -> list[Placement]:
    """Each metric the drive and the population share, with the drive's percentile."""
    from ..study.runner import PER_ITEM

    out = []
    for metric in sorted(m for m in set(drive) & set(population) if not PER_ITEM.search(m)):
        values = [v for v in population[metric] if math.isfinite(v)]
        median = float(np.median(values)) if values else math.nan
        out.append(Placement(metric, drive[metric], percentile_rank(drive[metric], values), len(values), median))
    return out


def against(
    drive: Any,
    rows: list[tuple[str, str, Any, str]],
    spec: str,
    env_id: str | None = None,
    condition: str | None = None,
    study_task: str | None = None,
    task: str | None = None,
) -> tuple[list[Placement], str]:
    """Place an analysed drive (`record.drive.Drive` and its `Analysis.rows()`) within `spec`.

    An env recording is replayed through its env for the env's own episode_metrics (the names a
    study table and a simulated population use); other drives are measured by the analyzer."""
    from .episodes import from_recording

    meta = drive.meta
    episode = None
    if drive.source == "mcap" and meta.get("env_id"):
        episode = from_recording(drive.path)
        target, kwargs = episode.env_spec.id, dict(episode.env_spec.kwargs)
    elif env_id is not None:
        from ..envs.registration import resolve_env_id

        target, kwargs = resolve_env_id(env_id)
    elif task or meta.get("task_path"):
        target, kwargs = "OpenDS/DrivingTask-v0", {"task": str(Path(str(task or meta["task_path"])).resolve())}
    else:
        target, kwargs = "", {}
    metrics = drive_metrics(rows, episode.metrics if episode is not None else None)
    if spec.startswith("population:"):
        if not target:
            raise UserError(f"{drive.path}: say which env the population drives: --env ENV_ID (or --task)")
        population, label = simulated_population(spec, target, kwargs)
    else:
        population, label = study_population(spec, study_task, condition)
    placements = place(metrics, population)
    if not placements:
        raise UserError(f"{spec}: shares no metric with the drive (population: {', '.join(sorted(population)) or 'none'})")
    return placements, label
