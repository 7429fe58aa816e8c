"""`NativeVectorEnv`: N OpenDS envs of one id as one `gymnasium.vector.VectorEnv`.

Why: `SyncVectorEnv` steps N single envs in a Python loop; this steps them together as
numpy arrays (see `core.BatchCore`), for the Lane Change Test, the brake reaction test and
the platoon test on the fast backend. `gymnasium.make_vec(id, num_envs=N,
vectorization_mode="vector_entry_point", **kwargs)` returns it.

Same results as the single env: for seeds s_i and the same actions, env i's observations,
rewards, terminated/truncated flags, info numbers and `episode_metrics` equal those of
`gymnasium.make(id, **kwargs)` reset with seed s_i and stepped with those actions, bit for
bit (tested): the per-step maths are compiled loops over the envs that call the single env's
own kernels (`sim.ego.kernels`, `sim.traffic.motion`) or repeat its arithmetic (`kernels`).

Vector API: autoreset mode NEXT_STEP (Gymnasium's default; the step after an episode ends
resets that env, with reward 0 and both flags False), seeding as `SyncVectorEnv`
(`reset(seed=s)` seeds env i with s + i, a list seeds each env, later autoresets continue
each env's generator), info as a dict of arrays with `_key` masks and `episode_metrics` as
a nested dict on the steps where episodes end. Differences: the `events` info key (the
per-step event log) is not produced, nor rendering.

Options: `record_metrics=False` skips the per-step traces (and `episode_metrics`); they
take ~0.5 MB per env for the LCT's 300 s limit, and a batch whose traces would not fit in
memory is refused. Parallelism: the Lane Change Test's, brake test's and platoon test's step
kernels run chunks of envs on numba's thread pool (`NUMBA_NUM_THREADS`, one per core by
default; `numba.set_num_threads`), so one process uses every core with no Python per chunk.
`threads` splits the envs into shards stepped in Python threads as well (the kernels release
the GIL).
`processes=N` runs N shards in separate processes instead (`opends_gym.vector.shards`): the
first in the calling process, each other one in a worker process of its own (spawned), each
with its share of numba's threads, at the price of a pipe round trip per step for the
workers.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import gymnasium as gym
import numba
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..envs.observations import EGO_NAMES, VEHICLE_NAMES
from ..jit import parallel_allowed
from .actions import first_nonfinite
from .core import BatchCore
from .episode_rows import InfoBlocks, metrics_arrays, table_rows
from .shards import LocalShard, ProcessShard, ShardMetrics
from .trace import _physical_memory


class NativeVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """N envs of one OpenDS id stepped as arrays; see the module docstring."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        env_id: str,
        batch_cls: type[BatchCore],
        num_envs: int,
        record_metrics: bool = True,
        threads: int | None = None,
        processes: int | None = None,
        **kwargs: Any,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, not {num_envs}")
        if kwargs.get("physics", "fast") != "fast":
            raise ValueError(
                f"the native batch of {env_id} simulates physics='fast' only; for physics={kwargs['physics']!r} use "
                f"gymnasium.make_vec({env_id!r}, num_envs={num_envs}, vectorization_mode='sync' (or 'async'), physics=...)"
            )
        if kwargs.pop("render_mode", None) is not None:
            raise ValueError("the native batch does not render; use vectorization_mode='sync' to render")
        kwargs.pop("max_episode_steps", None)
        if kwargs.get("on_road_exit", "terminate") != "terminate":
            raise ValueError(
                f"the native batch of {env_id} ends episodes on leaving the road (on_road_exit='terminate') only; for "
                f"on_road_exit={kwargs['on_road_exit']!r} use gymnasium.make_vec({env_id!r}, num_envs={num_envs}, "
                "vectorization_mode='sync')"
            )
        if kwargs.get("on_collision") not in (None, "terminate"):
            raise ValueError(
                f"the native batch of {env_id} handles collisions with terminate_on_collision only; for "
                f"on_collision={kwargs['on_collision']!r} use gymnasium.make_vec({env_id!r}, num_envs={num_envs}, "
                "vectorization_mode='sync')"
            )
        template: Any = gym.make(env_id, disable_env_checker=True, **kwargs).unwrapped
        if template.config.observation != "kinematics":
            raise ValueError(f"the native batch supports the kinematics observation, not {template.config.observation!r}")
        if template.config.road_preview_m:
            raise ValueError(
                f"the native batch has no road preview (road_preview_m); use gymnasium.make_vec({env_id!r}, vectorization_mode='sync')"
            )
        self.env_id = env_id
        self.num_envs = num_envs
        if record_metrics:
            cfg = template.config
            rows = math.ceil(cfg.max_episode_s * cfg.physics_hz) + 2 * cfg.action_repeat + 2
            need = rows * num_envs * len(batch_cls.trace_columns) * 8
            if need > 0.6 * _physical_memory():
                raise MemoryError(
                    f"the episode traces of {num_envs} envs need {need / 2**30:.1f} GiB (for episode_metrics); "
                    "use fewer envs, a shorter max_episode_s, or record_metrics=False"
                )
        if processes is not None and threads not in (None, 1):
            raise ValueError("choose threads or processes for the shards, not both")
        if processes is not None and processes < 1:
            raise ValueError(f"processes must be at least 1, not {processes}")
        shards = max(1, min(processes, num_envs)) if processes is not None else _shard_count(num_envs, threads, batch_cls.parallel_kernels)
        bounds = np.linspace(0, num_envs, shards + 1).astype(int)
        self._slices = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
        self._k = int(template.config.nearby_vehicles)
        self._obs_size = len(EGO_NAMES) + self._k * len(VEHICLE_NAMES) + len(template.stimulus_names)
        self.shards: list[LocalShard | ProcessShard] = []
        self._pool: ThreadPoolExecutor | None = None
        if processes is not None and shards > 1:
            # the calling process steps the first shard itself (no round trip for it), a worker each of the others
            probe = batch_cls(template, 1, False).info()  # the info keys and their types, for the shared arrays
            info_dtypes = {key: np.asarray(v).dtype.str for key, v in probe.items()}
            first = self._slices[0]
            each = max(1, numba.get_num_threads() // shards)  # numba threads per process: the cores shared out
            self.shards.append(LocalShard(batch_cls(template, first.stop - first.start, record_metrics), self._k, self._obs_size, each))
            for i, sl in enumerate(self._slices[1:], start=1):
                try:
                    n = sl.stop - sl.start
                    self.shards.append(
                        ProcessShard(env_id, batch_cls, n, record_metrics, kwargs, self._k, self._obs_size, info_dtypes, i, each)
                    )
                except BaseException:
                    self.close_extras()
                    raise
        else:
            templates = [template] + [gym.make(env_id, disable_env_checker=True, **kwargs).unwrapped for _ in range(shards - 1)]
            cores = [batch_cls(t, sl.stop - sl.start, record_metrics) for t, sl in zip(templates, self._slices)]  # type: ignore[arg-type]
            if shards > 1:  # (numba's workqueue layer, the fallback, takes one caller at a time: each thread steps its shard serially)
                for core in cores:
                    if hasattr(core, "parallel"):
                        core.parallel = False
            self.shards = [LocalShard(c, self._k, self._obs_size) for c in cores]
            # the calling thread steps the first shard itself; the pool the others
            self._pool = ThreadPoolExecutor(max_workers=shards - 1, thread_name_prefix="opends-native") if shards > 1 else None
        self.record_metrics = record_metrics
        self.single_observation_space = template.observation_space
        self.single_action_space = template.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._started = False
        self._info_blocks = InfoBlocks()  # `episode_metrics`' blocks, reused once the caller holds none of their arrays

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed if isinstance(seed, int) else None)
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"reset(seed=list) needs {self.num_envs} seeds, got {len(seeds)}")
        if options is not None and "reset_mask" in options:
            raise ValueError("reset_mask belongs to the DISABLED autoreset mode; this env autoresets on the next step")
        if not parallel_allowed():
            self._serial_cores()
        parts = [shard.reset(seeds[sl]) for shard, sl in zip(self.shards, self._slices)]
        self._autoreset[:] = False
        self._started = True
        obs = _join([p[0] for p in parts])
        values = _concat([p[1] for p in parts])
        return obs, self._info_dict(values, [[] for _ in parts])

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if not parallel_allowed():
            self._serial_cores()
        a = np.asarray(actions)
        if a.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {a.shape}")
        first = self.shards[0]
        if len(self.shards) > 1 or not getattr(getattr(first, "core", None), "checks_actions", False):
            _check_actions(a, ~self._autoreset)  # every shard's, before any shard steps (a lone batch that checks them: its step)
        jobs = [(shard, a[sl], self._autoreset[sl]) for shard, sl in zip(self.shards, self._slices)]
        # start the other shards (worker processes or pool threads), step the first one here, then collect
        collect: list[Callable[[], Any]] = []
        for shard, actions, resetting in jobs[1:]:
            if isinstance(shard, ProcessShard):
                shard.send_step(actions, resetting)
                collect.append(shard.receive)
            else:
                assert self._pool is not None
                collect.append(self._pool.submit(shard.step, actions, resetting).result)
        first, actions, resetting = jobs[0]
        parts = [first.step(actions, resetting)] + [get() for get in collect]
        for part, sl in zip(parts, self._slices):
            err = part[-1]
            if err is not None:  # name the env in the whole batch, not in its shard
                raise type(err)(_renumber(str(err), sl.start)) from err
        obs, reward, terminated, truncated = (_join([p[i] for p in parts]) for i in range(4))
        ended = terminated | truncated
        info = self._info_dict(_concat([p[4] for p in parts]), [p[5] for p in parts])
        self._autoreset = ended
        return obs, reward, terminated, truncated, info

    def _serial_cores(self) -> None:
        """This process was forked from one that had loaded numba's OpenMP threads
        (`jit.parallel_allowed`): its cores step with their kernels' serial twins."""
        for shard in self.shards:
            core = getattr(shard, "core", None)
            if getattr(core, "parallel", False):
                core.parallel = False  # type: ignore[union-attr]

    def close_extras(self, **kwargs: Any) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
        for shard in self.shards:
            shard.close()

    # ------------------------------------------------------------------ outputs
    def _info_dict(self, values: dict[str, np.ndarray], ended_metrics: list[ShardMetrics]) -> dict[str, Any]:
        """Info arrays with their `_key` masks, plus `episode_metrics` of the episodes that
        ended (each shard's `shards.ShardMetrics`: a table, or a list of (env in the shard,
        metrics)). Tables become the info arrays without a dict per episode."""
        full = np.ones(self.num_envs, dtype=bool)
        info: dict[str, Any] = {name: item for k, v in values.items() for name, item in ((k, v), (f"_{k}", full))}
        parts = [(sl, part) for sl, part in zip(self._slices, ended_metrics) if part]
        if parts:
            mask = np.zeros(self.num_envs, dtype=bool)
            if all(isinstance(part, tuple) for _, part in parts):
                tables = [([sl.start + e for e in part[0]], part[1]) for sl, part in parts if isinstance(part, tuple)]
                for envs, _ in tables:
                    mask[envs] = True
                info["episode_metrics"] = metrics_arrays(tables, self.num_envs, self._info_blocks)
            else:  # (a core without `episodes_table`: its dicts' value types decide the arrays')
                ended = [(sl.start + e, m) for sl, part in parts for e, m in _as_dicts(part)]
                mask[[e for e, _ in ended]] = True
                info["episode_metrics"] = _metrics_arrays(ended, self.num_envs)
            info["_episode_metrics"] = mask
        return info


def _as_dicts(part: ShardMetrics) -> list[tuple[int, dict[str, float]]]:
    """A shard's ended-episode metrics as (env in the shard, metrics) pairs."""
    if isinstance(part, tuple):
        return list(zip(part[0], table_rows(part[1]), strict=True))
    return part


def _metrics_arrays(ended: list[tuple[int, dict[str, float]]], n: int) -> dict[str, Any]:
    """The ended episodes' metrics as `_add_numbers` builds them one by one (each key's array
    and mask in the order keys first appear), a block at a time when every value is a float
    (the usual case; episodes of one task may differ in keys, e.g. the LCT's per-sign keys)."""
    first = ended[0][1]
    keys = tuple(first)
    floats = {float, np.float64}
    if not all(set(map(type, m.values())) <= floats for _, m in ended):
        out: dict[str, Any] = {}
        for e, values in ended:
            _add_numbers(out, values, e, n)
        return out
    rows = np.fromiter((e for e, _ in ended), dtype=np.intp, count=len(ended))
    if all(tuple(m) == keys for _, m in ended):
        table = np.array([tuple(m.values()) for _, m in ended], dtype=np.float64)
        present = None
    else:  # the union of the keys, in order of first appearance; absent values stay 0 with a False mask
        order: dict[str, int] = {}
        for _, m in ended:
            for key in m:
                order.setdefault(key, len(order))
        keys = tuple(order)
        table = np.zeros((len(ended), len(keys)))
        present = np.zeros((len(ended), len(keys)), dtype=np.bool_)
        for j, (_, m) in enumerate(ended):
            at = [order[key] for key in m]
            table[j, at] = tuple(m.values())
            present[j, at] = True
    # every key's column and mask as rows of two blocks (two allocations, not two per key)
    columns, masks = np.zeros((len(keys), n)), np.zeros((len(keys), n), dtype=np.bool_)
    columns[:, rows] = table.T
    masks[:, rows] = True if present is None else present.T
    out = {}
    for j, key in enumerate(keys):
        out[key], out[f"_{key}"] = columns[j], masks[j]
    return out


def _add_numbers(out: dict[str, Any], values: dict[str, float], e: int, n: int) -> None:
    """Gymnasium's `VectorEnv._add_info` for a flat dict of numbers (each key an array typed
    by its first value, with a `_key` mask), without its per-call overhead."""
    for key, value in values.items():
        array = out.get(key)
        if array is None:
            array = out[key] = np.zeros(n, dtype=type(value))
            out[f"_{key}"] = np.zeros(n, dtype=np.bool_)
        array[e] = value
        out[f"_{key}"][e] = True


def _shard_count(num_envs: int, threads: int | None, parallel_kernels: bool) -> int:
    """Shards stepped in parallel Python threads: by default one for a batch whose kernels run
    their chunks of envs on numba's threads themselves (`parallel_kernels`), else one per CPU
    (at most 4) once the shards are large enough for that to pay (numpy releases the GIL in
    its loops)."""
    if threads is None:
        threads = 1 if parallel_kernels or num_envs < 2048 else min(4, os.cpu_count() or 1)
    if threads < 1:
        raise ValueError(f"threads must be at least 1, not {threads}")
    return max(1, min(threads, num_envs))


def _join(parts: list[np.ndarray]) -> np.ndarray:
    """The shards' arrays as one (a single shard's as it is: its arrays are fresh each step)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _concat(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    if len(parts) == 1:  # (a single shard's info arrays are fresh each step, as `_join` takes them)
        return parts[0]
    return {k: _join([p[k] for p in parts]) for k in parts[0]}


def _check_actions(a: np.ndarray, stepping: np.ndarray) -> None:
    """Refuse a batch with a non-numeric or NaN/inf action in a stepping env, before any shard
    steps (a later shard's error used to leave the earlier shards a step ahead)."""
    try:
        values = np.ascontiguousarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"actions must be numbers, got dtype {a.dtype}") from None
    e = first_nonfinite(values.reshape(len(values), -1), stepping)  # (one compiled pass)
    if e >= 0:
        raise ValueError(f"env {e}: action contains NaN or infinity: {values[e].tolist()}")


def _renumber(message: str, offset: int) -> str:
    """'env 3: ...' of a shard starting at `offset` -> 'env 3+offset: ...'."""
    if offset and message.startswith("env "):
        head, _, rest = message[4:].partition(":")
        if head.isdigit():
            return f"env {int(head) + offset}:{rest}"
    return message
