"""`opends-gym compile`: compile every kernel a first step needs into this machine's numba cache.

Why: numba's machine code is specific to the machine's CPU, so it cannot ship in the wheel;
without this, the first native batch of each kind on a machine waits for its kernels'
compile (36-75 s for 4,096 envs, docs/performance.md "Cold start"), and single envs run
their kernels as Python until the background compile is done. This drives each registered
env and each native batch a few steps (with short episodes, so episode ends and autoresets
run too) in worker processes, one per core (a compile is CPU bound and holds the GIL;
groups that share kernels go to one worker, see `chains`), waits for the background compiles, and so leaves every
kernel they call in the cache where later processes look (numba's cache locators:
`NUMBA_CACHE_DIR` if set, else the `__pycache__` folders next to the package when they are
writable, else numba's user-wide cache). Run it as the user who will run the envs. With a
warm cache it only loads the kernels (a few seconds).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..hints import did_you_mean

SHORT_EPISODE_S = 1.0  # episodes this long end within a few policy steps (episode end and autoreset get compiled too)
MAX_STEPS = 40  # policy steps per env or batch at most


@dataclass(frozen=True)
class Group:
    """One env id as a single env or as a native batch: one line of the output."""

    env_id: str
    native: bool
    kwargs: dict[str, Any] = field(default_factory=dict, hash=False)

    @property
    def label(self) -> str:
        task = f" ({self.kwargs['task']})" if "task" in self.kwargs else ""
        return f"{self.env_id}{task} {'native batch' if self.native else 'single env'}"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--only", nargs="+", metavar="ENV_ID", help="only these env ids (or short names: LaneChangeTest)")
    p.add_argument("--kind", choices=("all", "single", "native"), default="all", help="single envs, native batches or both (all)")
    p.add_argument(
        "--task", nargs="+", default=[], metavar="FOLDER", help="also your own tasks on OpenDS/DrivingTask-v0 (single env and native batch)"
    )
    p.add_argument("--jobs", type=int, default=None, help="worker processes (default: one per core)")


def run(args: argparse.Namespace) -> int:
    groups = plan(args.only, args.kind, args.task)
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    if jobs < 1:
        raise UserError(f"--jobs must be at least 1, not {jobs}")
    return compile_groups(groups, jobs)


def plan(only: list[str] | None, kind: str, tasks: list[str]) -> list[Group]:
    """The groups to compile."""
    from ..envs.registration import ENVS, VECTOR_ENVS, lookup_env_id
    from ..task.bundled import bundled_task_names

    ids = list(ENVS)
    if only:
        names = ids + [i.removeprefix("OpenDS/").removesuffix("-v0") for i in ids]
        ids = []
        for name in only:
            env_id = lookup_env_id(name)
            if env_id is None or env_id not in ENVS:
                raise UserError(f"unknown environment id {name!r}{did_you_mean(name, names)} (opends-gym list --envs shows them)")
            if env_id not in ids:
                ids.append(env_id)
    for t in tasks:
        if not Path(t).exists() and t not in bundled_task_names():
            raise UserError(f"{t}: no such task folder or file, nor a bundled task (opends-gym list --tasks shows them)")
    groups: list[Group] = []
    if kind in ("all", "native"):
        groups += [Group(i, True) for i in ids if i in VECTOR_ENVS]
        groups += [Group("OpenDS/DrivingTask-v0", True, {"task": t}) for t in tasks]
    if kind in ("all", "single"):
        groups += [Group(i, False) for i in ids]
        groups += [Group("OpenDS/DrivingTask-v0", False, {"task": t}) for t in tasks]
    return groups


# groups that compile many of the same kernels: one worker runs them one after the other, so
# the later ones load what the first compiled instead of compiling it again at the same time
_TRAFFIC_IDS = ("OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0")
_FAMILIES = {(i, True): "platoon batches" for i in _TRAFFIC_IDS} | {(i, False): "traffic envs" for i in _TRAFFIC_IDS}


def chains(groups: list[Group]) -> list[list[Group]]:
    """The groups as the worker tasks that run them: a family (`_FAMILIES`, the other single
    envs without a task of yours) in one task, in the given order; any other group alone.
    The longest first: tasks with traffic (sim.traffic, vector.platoon*, vector.driving*)."""
    out: list[list[Group]] = []
    where: dict[str, list[Group]] = {}
    for g in groups:
        family = _FAMILIES.get((g.env_id, g.native)) or ("single envs" if not g.native and not g.kwargs else None)
        if family is None:
            out.append([g])
        elif family in where:
            where[family].append(g)
        else:
            where[family] = [g]
            out.append(where[family])
    return sorted(out, key=lambda c: (not c[0].native, not any(_with_traffic(g) for g in c)))


def _with_traffic(g: Group) -> bool:
    return not g.kwargs and (g.env_id in _TRAFFIC_IDS or (g.native and g.env_id == "OpenDS/DrivingTask-v0"))


def compile_groups(groups: list[Group], jobs: int) -> int:
    """Compile the groups in `jobs` spawned worker processes, lines per chain of groups as it ends."""
    import multiprocessing

    start = time.perf_counter()
    failed = 0
    caches: set[str] = set()
    width = max((len(g.label) for g in groups), default=0)
    tasks = chains(groups)
    workers = max(1, min(jobs, len(tasks)))
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures: dict[Future[list[dict[str, Any]]], list[Group]] = {pool.submit(compile_chain, c): c for c in tasks}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                chain = futures[future]
                try:
                    results = future.result()
                except Exception as e:  # the worker died: its groups failed, the others go on
                    results = [{"failed": _one_line(e)}] * len(chain)
                for group, r in zip(chain, results):
                    if "failed" in r:
                        failed += 1
                        print(f"{group.label:<{width}}  failed: {r['failed']}", flush=True)
                    elif "skipped" in r:
                        print(f"{group.label:<{width}}  skipped: {r['skipped']}", flush=True)
                    else:
                        caches.add(r["cache"] or "none (NUMBA_DISABLE_JIT)")
                        print(
                            f"{group.label:<{width}}  {r['seconds']:6.1f} s  {r['compiled']:4d} compiled  "
                            f"{r['loaded']:4d} loaded from the cache",
                            flush=True,
                        )
    for cache in sorted(caches):
        print(f"numba cache (of opends_gym/jit.py's kernels; other modules' alike): {cache}")
    print(f"{len(groups) - failed} of {len(groups)} groups in {time.perf_counter() - start:.1f} s ({workers} worker processes)")
    if failed:
        print(f"opends-gym compile: error: {failed} group(s) failed (see above)", file=sys.stderr)
        return 1
    return 0


def _one_line(e: BaseException) -> str:
    return "; ".join(line.strip() for line in str(e).splitlines() if line.strip()) or type(e).__name__


def compile_chain(chain: list[Group]) -> list[dict[str, Any]]:
    """In a worker process: `compile_group` for each group in turn; a failure is reported and
    the next group goes on."""
    results: list[dict[str, Any]] = []
    for group in chain:
        try:
            results.append(compile_group(group))
        except Exception as e:
            results.append({"failed": _one_line(e)})
    return results


def compile_group(group: Group) -> dict[str, Any]:
    """In a worker process: drive the group's env, wait for its compiles, count what numba did."""
    import logging
    import warnings

    start = time.perf_counter()
    from .. import jit

    warnings.simplefilter("ignore")  # a task's warnings belong to the runs that use it, not to this
    logging.getLogger("opends_gym").setLevel(logging.ERROR)
    before = jit.cache_stats()  # (a worker runs several groups: kernels an earlier one got are counted there)
    drive: Callable[[Group], None] = _drive_native if group.native else _drive_single
    try:
        with jit.compile_in_call():  # (in this worker: the compile is the point, not stepping as Python meanwhile)
            drive(group)
    except ValueError as e:  # your task's native batch refused it (no traffic, a feature it does not model)
        if not (group.native and "task" in group.kwargs):
            raise
        return {"skipped": str(e).split("; ")[0]}
    jit.wait_compiled()
    after = jit.cache_stats()
    cache = str(jit.py_hypot.stats.cache_path) if hasattr(jit.py_hypot, "stats") else None  # (one kernel's folder: where they all go)
    return {"seconds": time.perf_counter() - start, "cache": cache, **{k: after[k] - before[k] for k in after}}


def _drive_single(group: Group) -> None:
    """Reset, step past an episode end, reset and step again (the kernels compile in their calls)."""
    import gymnasium as gym

    env = gym.make(group.env_id, max_episode_s=SHORT_EPISODE_S, disable_env_checker=True, **group.kwargs)
    try:
        env.action_space.seed(0)
        env.reset(seed=0)
        ended = 0
        for _ in range(MAX_STEPS):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                ended += 1
                env.reset(seed=ended)
                if ended == 2:
                    break
    finally:
        env.close()


def _drive_native(group: Group) -> None:
    """A batch of one chunk (serial kernels) and one of more (numba-parallel kernels), each
    stepped until every env has ended an episode and been reset (or MAX_STEPS)."""
    import gymnasium as gym
    import numpy as np

    from ..vector.kernels import CHUNK_ENVS

    if group.env_id in ("OpenDS/BrakeReaction-v0", "OpenDS/ThreeVehiclePlatoon-v0"):
        from ..vector.platoon_controls import compile_parallel_controls

        compile_parallel_controls()  # (only batches larger than those below call it)
    tasks: list[dict[str, Any]] = [dict(group.kwargs)]
    if group.env_id == "OpenDS/DrivingTask-v0" and "task" not in group.kwargs:
        tasks = [{"task": str(t)} for t in _traffic_tasks()]
    for kwargs in tasks:
        for n in (2, CHUNK_ENVS + 1):
            env = gym.make_vec(group.env_id, num_envs=n, vectorization_mode="vector_entry_point", max_episode_s=SHORT_EPISODE_S, **kwargs)
            try:
                env.action_space.seed(0)
                env.reset(seed=0)
                ended = np.zeros(n, dtype=bool)
                for _ in range(MAX_STEPS):
                    _, _, terminated, truncated, _ = env.step(env.action_space.sample())
                    if ended.all():  # this step autoreset them
                        break
                    ended |= terminated | truncated
            finally:
                env.close()


def _traffic_tasks() -> list[Any]:
    """Tasks with traffic for the native DrivingTask batch (no bundled task is one it runs): the
    bundled platoon task's road, cars and trigger boxes, its triggers starting a recording
    instead of the platoon's stimuli (which the batch does not run), saved to a temporary folder; once with its
    lanes, once without (the ego car then follows a route along the cars' paths). Between
    them they call every kernel of the batch: lanes, routes and trigger-box contacts."""
    import atexit
    import shutil
    import tempfile
    from dataclasses import replace
    from pathlib import Path

    from ..task import load_task, save_task
    from ..task.model_interaction import Action, Activity, Interaction, Parameter
    from ..task.model_road import Road

    task = load_task("ThreeVehiclePlatoon")
    record = Activity(actions=(Action(name="startRecording", params=(Parameter(name="track", value="1"),)),))
    task = replace(task, interaction=Interaction(triggers=tuple(replace(t, activities=(record,)) for t in task.interaction.triggers)))
    folder = Path(tempfile.mkdtemp(prefix="opends-gym-compile-"))
    atexit.register(shutil.rmtree, folder, True)
    return [
        save_task(task, folder / "Lanes"),
        save_task(replace(task, scenario=replace(task.scenario, road=Road())), folder / "Route"),
    ]
