"""Where a study's virtual trials run: the native batch (`study.native`) or single envs (`study.runner`).

Why a module of its own: the study's `backend` (auto, native, single) splits the trials
between the two, and the rows go back together in design order, so the table does not
depend on which backend drove which trial.
"""

from __future__ import annotations

from collections.abc import Callable

from .design import Trial
from .native import choose, run_native_trials
from .runner import Row, run_single


def run_trials(
    trials: list[Trial],
    participants: int,
    seed: int,
    workers: int = 1,
    cluster: str | None = None,
    use_ray: bool = False,
    progress: Callable[[int, int], None] | None = None,
    backend: str = "auto",
) -> list[Row]:
    """Every trial's rows, in design order: the trials `backend` puts on the native batch
    there, the others on single envs (here, a process pool or Ray)."""
    native = choose(trials, backend, on_ray=cluster is not None or use_ray)
    batched = [t for t, n in zip(trials, native) if n]
    on_batch = iter(run_native_trials(batched, participants, seed, workers, progress) if batched else [])
    single = [t for t, n in zip(trials, native) if not n]
    on_single = iter(run_single(single, participants, seed, workers, cluster, use_ray, progress))
    return [row for n in native for row in next(on_batch if n else on_single)]
