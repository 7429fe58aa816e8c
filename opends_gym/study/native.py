"""Run a study's trials on the native batch (`backend: native`, or `auto` where a task has one).

Why: the single env spends most of a drive in Python physics; the native batch steps the
physics, triggers and metrics of many drives in compiled code, while each drive's virtual
participant (the one `drivers.participant` model, reading its env slot through
`drivers.percept`) still acts per env in Python. Trials stream through the batch's slots:
a slot whose drive ended is reset with the next trial's seed, so the table is the single
env's, row for row (tested).

Leaving the road: the batch ends a drive there (`on_road_exit="terminate"`). Up to that
moment the drive is the one a `recover` or `continue` env drives; a drive that left the
road under such a study is driven again, whole, on the single env, so its rows are those of
the study's own `on_road_exit` too. Collisions likewise: the batch ends a drive on its first
collision, and a drive that collided under `on_collision="recover"` or `"continue"` (the study
default) is driven again on the single env.
"""

from __future__ import annotations

import math
import multiprocessing
from collections import deque
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from ..errors import UserError
from .config import BACKENDS
from .design import Trial
from .runner import Row, run_trial, trial_agent, trial_rows

BATCH_ENVS = 256  # slots of one batch (each keeps its drive's trace: ~0.5 MB for the LCT)
PART_TRIALS = 64  # trials of one worker's part at least (each part builds a batch)


def native_reason(trial: Trial) -> str | None:
    """Why `trial` cannot run on a native batch, or None when it can."""
    from ..vector.slots import supports

    if trial.drt is not None:
        return "the DRT wrapper has no native batch"
    if not trial.agent.startswith("participant:"):
        return f"agent {trial.agent}: only the virtual participant drives native slots"
    return supports(trial.env_id, _batch_args(trial))


def choose(trials: list[Trial], backend: str, on_ray: bool) -> list[bool]:
    """Per trial: run it on the native batch? `auto`: where it can (not on Ray, which runs
    the single env); `native`: every trial, or a one-line error naming the first that cannot."""
    if backend not in BACKENDS:
        raise UserError(f"backend must be one of {', '.join(BACKENDS)}, not {backend!r}")
    if backend == "single":
        return [False] * len(trials)
    if backend == "native":
        if on_ray:
            raise UserError("backend native runs on this machine (--workers); Ray runs the single env (backend: single or auto)")
        for t in trials:
            why = native_reason(t)
            if why is not None:
                raise UserError(f"backend native: task {t.task}, condition {t.condition}: {why} (use backend: auto or single)")
        return [True] * len(trials)
    return [not on_ray and native_reason(t) is None for t in trials]


def _batch_args(trial: Trial) -> dict[str, Any]:
    args = dict(trial.env_args)
    args.pop("on_road_exit", None)  # (the batch terminates; see the module docstring)
    args.pop("on_collision", None)
    return args


def _exits_matter(trial: Trial) -> bool:
    return dict(trial.env_args).get("on_road_exit", "terminate") != "terminate"


def _collisions_matter(trial: Trial) -> bool:
    return dict(trial.env_args).get("on_collision", "terminate") != "terminate"


def _redrive(trial: Trial, left_road: bool, metrics: dict[str, Any]) -> bool:
    """Did the batch end this drive where the study's own env would have gone on?"""
    collided = float(metrics.get("collisions", 0.0)) > 0
    return (left_road and _exits_matter(trial)) or (collided and _collisions_matter(trial))


def run_native(
    trials: list[Trial], participants: int, seed: int, batch_envs: int = BATCH_ENVS, done: Callable[[int], None] | None = None
) -> list[list[Row]]:
    """The rows of each trial (in the order given), driven on native batches in this process;
    `done(k)` after each k trials."""
    out: list[list[Row] | None] = [None] * len(trials)
    groups: dict[str, list[int]] = {}
    for i, t in enumerate(trials):
        groups.setdefault(repr((t.env_id, sorted(_batch_args(t).items()))), []).append(i)
    for idx in groups.values():
        _run_group(trials, idx, participants, seed, batch_envs, out, done)
    return [rows if rows is not None else [] for rows in out]


def _run_group(
    trials: list[Trial],
    idx: list[int],
    participants: int,
    seed: int,
    batch_envs: int,
    out: list[list[Row] | None],
    done: Callable[[int], None] | None,
) -> None:
    """Trials `idx` (one env id and options) streamed through one batch's slots."""
    from ..drivers.episodes import with_glances
    from ..vector.slots import SlotBatch

    first = trials[idx[0]]
    try:
        batch = SlotBatch(first.env_id, min(batch_envs, len(idx)), _batch_args(first))
    except (TypeError, ValueError) as err:
        raise UserError(f"{first.env_id}: {err}") from None
    queue = deque(idx)
    agents: list[Any] = [None] * batch.n
    which = [-1] * batch.n

    def start(e: int) -> None:
        i = queue.popleft()
        t = trials[i]
        agent = trial_agent(t, participants, seed)
        batch.reset(e, t.seed)  # (the single path's order: env.reset, then agent.reset)
        agent.reset(batch.slots[e], t.seed)
        agents[e], which[e] = agent, i

    try:
        for e in range(batch.n):
            start(e)
        while batch.running.any():
            for e, left_road, metrics in batch.step(lambda e: agents[e].act(None, None)):
                t = trials[which[e]]
                if _redrive(t, left_road, metrics):  # the study's own on_road_exit/on_collision: drive it again on the single env
                    out[which[e]] = run_trial(t, participants, seed)
                else:
                    out[which[e]] = trial_rows(t, with_glances(metrics, agents[e]))
                if done is not None:
                    done(1)
                if queue:
                    start(e)
    finally:
        batch.close()


def _run_part(trials: list[Trial], participants: int, seed: int, threads: int) -> list[list[Row]]:
    """A worker process's share (its numba threads limited so the workers share the cores)."""
    import numba

    numba.set_num_threads(max(1, min(threads, numba.get_num_threads())))
    return run_native(trials, participants, seed)


def run_native_trials(
    trials: list[Trial], participants: int, seed: int, workers: int = 1, progress: Callable[[int, int], None] | None = None
) -> list[list[Row]]:
    """`run_native` in this process (`workers` 1) or split over worker processes (spawned);
    `progress(participants done, participants)` as trials end."""
    total = len(trials)
    finished = [0]

    def done(k: int) -> None:
        finished[0] += k
        if progress is not None:
            progress(finished[0] * participants // max(total, 1), participants)

    if workers <= 1 or total <= PART_TRIALS:
        return run_native(trials, participants, seed, done=done)
    size = max(PART_TRIALS, math.ceil(total / (4 * workers)))  # a few parts per worker: no idle worker at the end
    parts = [trials[a : a + size] for a in range(0, total, size)]
    threads = max(1, (multiprocessing.cpu_count() or 1) // workers)
    ctx = multiprocessing.get_context("spawn")
    results: list[list[Row]] = []
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        for part, f in zip(parts, [pool.submit(_run_part, p, participants, seed, threads) for p in parts]):
            results.extend(f.result())
            done(len(part))
    return results
