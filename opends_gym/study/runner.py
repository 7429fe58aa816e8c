"""Run the virtual trials of a study: in this process, a process pool, or Ray.

Why chunks of one participant: a worker keeps the envs it made (one per task and condition
options) and resets them with each trial's seed, so a participant's trials cost one env build;
results are put back in design order, so the table does not depend on who ran what.
"""

from __future__ import annotations

import math
import multiprocessing
import re
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import gymnasium as gym

from ..errors import UserError
from .design import Trial, participant_label

PER_ITEM = re.compile(r"^sign\d+_|\[")  # per-sign / per-item keys are not study measures
COLUMNS = ("participant", "source", "condition", "task", "trial", "metric", "value")
Row = tuple[str, str, str, str, int, str, float]
Progress = Callable[[int, int], None] | None

_ENVS: dict[str, gym.Env[Any, Any]] = {}  # per worker process: trial key -> env


def scalar_metrics(metrics: dict[str, Any], wanted: tuple[str, ...] | None, where: str) -> list[tuple[str, float]]:
    """The (name, value) pairs of an episode that go into the table (`wanted`, or every scalar)."""
    if wanted is not None:
        missing = [m for m in wanted if m not in metrics]
        if missing:
            known = ", ".join(sorted(k for k in metrics if not PER_ITEM.search(k)))
            raise UserError(f"{where}: no metric {', '.join(missing)} in this episode (metrics: {known})")
        return [(m, _number(metrics[m])) for m in wanted]
    out = []
    for k, v in metrics.items():
        if PER_ITEM.search(k) or isinstance(v, (list, tuple, dict, str)) or v is None:
            continue
        out.append((k, _number(v)))
    return out


def _number(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _env_for(trial: Trial) -> gym.Env[Any, Any]:
    env = _ENVS.get(trial.key)
    if env is None:
        from ..envs.registration import register_envs

        register_envs()  # a fresh worker process has not registered the ids

        try:
            env = gym.make(trial.env_id, **dict(trial.env_args))
        except (TypeError, ValueError) as e:
            raise UserError(f"{trial.env_id}: {e}") from None
        if trial.drt is not None:
            from ..envs.drt import DetectionResponseTask

            env = DetectionResponseTask(env, **dict(trial.drt.options))
        _ENVS[trial.key] = env
    return env


def run_trial(trial: Trial, participants: int, seed: int) -> list[Row]:
    """One episode of one trial -> its table rows."""
    from ..drivers.episodes import run_episode

    ep = run_episode(_env_for(trial), trial_agent(trial, participants, seed), trial.seed)
    return trial_rows(trial, ep.metrics)


def trial_agent(trial: Trial, participants: int, seed: int) -> Any:
    """The driver of one trial (participant N of the study's population, or another agent spec)."""
    from .agents import make_trial_agent

    try:
        return make_trial_agent(trial.agent, participants, seed, f"task {trial.task}, condition {trial.condition}: ")
    except (ValueError, TypeError, OSError) as e:
        raise UserError(f"condition {trial.condition}: agent {trial.agent}: {e}") from None


def trial_rows(trial: Trial, metrics: dict[str, Any]) -> list[Row]:
    """The table rows of one trial's episode metrics (whichever backend drove it)."""
    label = participant_label(trial.participant)
    where = f"task {trial.task}, condition {trial.condition}"
    return [(label, "virtual", trial.condition, trial.task, trial.trial, m, v) for m, v in scalar_metrics(metrics, trial.metrics, where)]


def run_chunk(trials: list[Trial], participants: int, seed: int) -> list[list[Row]]:
    """Each trial's rows."""
    return [run_trial(t, participants, seed) for t in trials]


def chunks(trials: list[Trial]) -> list[list[Trial]]:
    """Trials grouped by participant, in design order."""
    out: dict[int, list[Trial]] = {}
    for t in trials:
        out.setdefault(t.participant, []).append(t)
    return list(out.values())


def run_trials(
    trials: list[Trial],
    participants: int,
    seed: int,
    workers: int = 1,
    cluster: str | None = None,
    use_ray: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> list[Row]:
    """Every trial's rows on single envs, in design order, whatever runs them (`study.backend`
    puts trials on the native batch too)."""
    return [row for rows in run_single(trials, participants, seed, workers, cluster, use_ray, progress) for row in rows]


def run_single(
    trials: list[Trial],
    participants: int,
    seed: int,
    workers: int,
    cluster: str | None,
    use_ray: bool,
    progress: Callable[[int, int], None] | None,
) -> list[list[Row]]:
    """Each trial's rows (in the order given) from single envs: here, a process pool or Ray."""
    if not trials:
        return []
    parts = chunks(trials)
    if cluster is not None or use_ray:
        results = _run_ray(parts, participants, seed, cluster, progress)
    elif workers <= 1:
        results = []
        for k, part in enumerate(parts):
            results.append(run_chunk(part, participants, seed))
            if progress is not None:
                progress(k + 1, len(parts))
    else:
        results = _run_pool(parts, participants, seed, workers, progress)
    return [rows for part in results for rows in part]


def _run_pool(
    parts: list[list[Trial]], participants: int, seed: int, workers: int, progress: Callable[[int, int], None] | None
) -> list[list[list[Row]]]:
    ctx = multiprocessing.get_context("spawn")  # no fork of a process with threads or open envs
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = [pool.submit(run_chunk, part, participants, seed) for part in parts]
        results = []
        for k, f in enumerate(futures):
            results.append(f.result())
            if progress is not None:
                progress(k + 1, len(parts))
    return results


def _run_ray(
    parts: list[list[Trial]], participants: int, seed: int, cluster: str | None, progress: Callable[[int, int], None] | None
) -> list[list[list[Row]]]:
    from ..extras import require

    ray = require("cluster", "ray", "running a study on Ray")
    if cluster is not None and not cluster.strip():
        raise UserError("--cluster: give the Ray address (ray://HOST:PORT, or auto)")
    started = not ray.is_initialized()
    if started:
        try:
            ray.init(address=cluster, ignore_reinit_error=True, include_dashboard=False, log_to_driver=False)
        except (ConnectionError, ValueError) as e:
            raise UserError(f"--cluster {cluster}: cannot connect to Ray: {e}") from None
    try:
        remote = ray.remote(run_chunk)
        refs = [remote.remote(part, participants, seed) for part in parts]
        results = []
        for k, ref in enumerate(refs):
            results.append(ray.get(ref))
            if progress is not None:
                progress(k + 1, len(parts))
    finally:
        if started:  # leave no Ray of ours running in the caller's process
            ray.shutdown()
    return results


def iter_rows(rows: Iterable[Row]) -> Iterable[dict[str, Any]]:
    for r in rows:
        yield dict(zip(COLUMNS, r))
