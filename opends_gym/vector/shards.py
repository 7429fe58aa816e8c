"""Where the shards of a native batch run: in this process or each in a worker process.

Why: the compiled kernels release the GIL but the Python between them holds it, so shards
stepped in threads of one process share one interpreter's worth of glue. Worker processes
(`processes=N`) run that glue in parallel too (before the LCT's kernels ran on numba's
threads, two independent processes of 2,048 LCT envs each ran side by side at the speed of
one alone here; the LCT batch now uses the cores from one process). A worker process gets actions over a
pipe and writes its observation, rewards, flags and info arrays into memory shared with the
caller; only the finished episodes' metrics travel back through the pipe. The arithmetic is
the same code as in process, so the results are identical (tested). The pipe round trip
costs ~0.6 ms per step, so processes pay off for large batches only.
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import traceback
from multiprocessing.connection import Connection
from typing import Any

import gymnasium as gym
import numba
import numpy as np

from ..envs.observations import EGO_NAMES, VEHICLE_NAMES
from .core import BatchCore
from .episode_table import EpisodeTable
from .kernels import ego_features

# obs, reward, terminated, truncated, info arrays, ended episodes' metrics (`ShardMetrics`), error
StepResult = tuple[Any, ...]
# the ended episodes' metrics of a shard's step: (envs in the shard, their table) from a core with `episodes_table`, else
# [(env in shard, metrics dict)] (empty: none ended)
ShardMetrics = tuple[list[int], EpisodeTable] | list[tuple[int, dict[str, Any]]]
SHARD_ERRORS = (ValueError, RuntimeError, FloatingPointError)  # bad input from the caller: raised in the caller


def step_shard(core: BatchCore, actions: np.ndarray, resetting: np.ndarray, k: int, obs_size: int) -> StepResult:
    """One shard's step with NEXT_STEP autoreset; errors of the caller's input are returned."""
    try:
        fused = getattr(core, "step_and_reset", None)
        if fused is not None:  # the batch steps, resets and fills its outputs itself (`LctBatch.step_and_reset`)
            obs, reward, terminated, truncated, values, ended = fused(actions, resetting, obs_size)
            return obs, reward, terminated, truncated, values, ended_metrics(core, ended), None
        stepping = ~resetting
        reward, terminated, truncated, values = core.step_rows(actions, stepping)
        if resetting.any():
            core.reset_rows(np.flatnonzero(resetting), None)
            fresh = core.info()
            values = {key: np.where(resetting, fresh[key], v) for key, v in values.items()}
        reward = np.where(stepping, reward, 0.0)
        ended = np.flatnonzero(terminated | truncated).tolist()
        return observe(core, k, obs_size), reward, terminated, truncated, values, ended_metrics(core, ended), None
    except SHARD_ERRORS as e:
        return (None,) * 6 + (e,)


def ended_metrics(core: BatchCore, ended: list[int]) -> ShardMetrics:
    """The metrics of the episodes that ended: the core's table where it has `episodes_table`
    (no dict per episode), else its `episodes_metrics` dicts."""
    if not core.record_metrics or not ended:
        return []
    table = getattr(core, "episodes_table", None)
    if table is not None:
        return ended, table(ended)
    return core.episodes_metrics(ended)


def reset_shard(core: BatchCore, seeds: list[int | None], k: int, obs_size: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    core.reset_rows(np.arange(core.n), seeds)
    return observe(core, k, obs_size), core.info()


class LocalShard:
    """A shard stepped in this process (in a worker thread when there are several); `threads`:
    numba threads for its kernels (None: numba's setting)."""

    def __init__(self, core: BatchCore, k: int, obs_size: int, threads: int | None = None) -> None:
        self.core, self.k, self.obs_size, self.threads = core, k, obs_size, threads

    def step(self, actions: np.ndarray, resetting: np.ndarray) -> StepResult:
        if self.threads is None:
            return step_shard(self.core, actions, resetting, self.k, self.obs_size)
        before = numba.get_num_threads()
        numba.set_num_threads(self.threads)
        try:
            return step_shard(self.core, actions, resetting, self.k, self.obs_size)
        finally:
            numba.set_num_threads(before)

    def reset(self, seeds: list[int | None]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        return reset_shard(self.core, seeds, self.k, self.obs_size)

    def close(self) -> None:
        self.core.template.close()


class SharedArrays:
    """The arrays a worker writes each step (observation, reward, flags, info values), in
    memory shared with the caller, so only actions and finished episodes' metrics travel
    through the pipe. Built by the caller before the worker starts (both map the same bytes)."""

    def __init__(self, layout: dict[str, tuple[tuple[int, ...], str]], ctx: Any) -> None:
        self.layout = layout
        self.buffers = {name: ctx.RawArray(ctypes.c_uint8, max(1, int(np.prod(shape)) * np.dtype(dtype).itemsize))
                        for name, (shape, dtype) in layout.items()}  # fmt: skip
        self.arrays = self._views()

    def _views(self) -> dict[str, np.ndarray]:
        out = {}
        for name, (shape, dtype) in self.layout.items():
            n = int(np.prod(shape))
            out[name] = np.frombuffer(self.buffers[name], dtype=dtype, count=n).reshape(shape)
        return out

    def __getstate__(self) -> dict[str, Any]:  # (spawn: the buffers travel, the views are rebuilt)
        return {"layout": self.layout, "buffers": self.buffers}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.layout, self.buffers = state["layout"], state["buffers"]
        self.arrays = self._views()


class ProcessShard:
    """A shard in a worker process of its own, started fresh (spawned: a process forked after
    numba's OpenMP thread pool started cannot use it), which builds its own env template and
    steps with `threads` numba threads. `send_step` and `receive` are split so the caller can
    start every shard before waiting for any."""

    def __init__(self, env_id: str, batch_cls: type[BatchCore], n: int, record_metrics: bool, kwargs: dict[str, Any], k: int,
                 obs_size: int, info_dtypes: dict[str, str], index: int, threads: int = 1) -> None:  # fmt: skip
        ctx: Any = mp.get_context("spawn")
        layout = {"obs": ((n, obs_size), "float32"), "reward": ((n,), "float64"), "terminated": ((n,), "bool"), "truncated": ((n,), "bool")}
        layout.update({f"info.{key}": ((n,), dtype) for key, dtype in info_dtypes.items()})
        self.shared = SharedArrays(layout, ctx)
        self._conn, child = ctx.Pipe()
        self.index = index
        args = (child, env_id, batch_cls, n, record_metrics, kwargs, k, obs_size, self.shared, threads)
        self._process = ctx.Process(target=_serve, args=args, name=f"opends-native-{index}", daemon=True)
        self._process.start()
        child.close()
        self._receive()  # wait until the worker has built its shard (or failed to)

    def send_step(self, actions: np.ndarray, resetting: np.ndarray) -> None:
        self._send(("step", actions, resetting))

    def _send(self, message: tuple[Any, ...]) -> None:
        try:
            self._conn.send(message)
        except (BrokenPipeError, OSError) as e:
            raise RuntimeError(f"native batch worker {self.index} died (exit code {self._process.exitcode})") from e

    def receive(self) -> StepResult:
        """The step started by `send_step`: copies of the shared arrays plus the metrics."""
        metrics, err = self._receive()
        if err is not None:
            return (None,) * 6 + (err,)
        a = self.shared.arrays
        values = {name[5:]: v.copy() for name, v in a.items() if name.startswith("info.")}
        return a["obs"].copy(), a["reward"].copy(), a["terminated"].copy(), a["truncated"].copy(), values, metrics, None

    def step(self, actions: np.ndarray, resetting: np.ndarray) -> StepResult:
        self.send_step(actions, resetting)
        return self.receive()

    def reset(self, seeds: list[int | None]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        self._send(("reset", seeds))
        self._receive()
        a = self.shared.arrays
        return a["obs"].copy(), {name[5:]: v.copy() for name, v in a.items() if name.startswith("info.")}

    def _receive(self) -> Any:
        try:
            status, payload = self._conn.recv()
        except (EOFError, OSError) as e:
            raise RuntimeError(f"native batch worker {self.index} died (exit code {self._process.exitcode})") from e
        if status == "error":
            raise RuntimeError(f"native batch worker {self.index} failed:\n{payload}")
        return payload

    def close(self) -> None:
        if self._process.is_alive():
            try:
                self._conn.send(("close", None))
                self._process.join(timeout=10)
            except (BrokenPipeError, OSError):
                pass
        if self._process.is_alive():
            self._process.terminate()
            self._process.join(timeout=5)
        self._conn.close()


def _serve(conn: Connection, env_id: str, batch_cls: type[BatchCore], n: int, record_metrics: bool, kwargs: dict[str, Any], k: int,
           obs_size: int, shared: SharedArrays, threads: int) -> None:  # fmt: skip
    """A worker process: build the shard, then answer step/reset requests until told to close."""
    try:
        numba.set_num_threads(threads)
        from ..envs.registration import register_envs

        register_envs()  # (a spawned interpreter has not registered them)

        template: Any = gym.make(env_id, disable_env_checker=True, **kwargs).unwrapped
        core = batch_cls(template, n, record_metrics)
        conn.send(("ok", None))
    except Exception:  # anything that stops the worker is reported to the caller
        conn.send(("error", traceback.format_exc()))
        return
    a = shared.arrays
    info_names = [(name, name[5:]) for name in a if name.startswith("info.")]
    while True:
        try:
            command, *args = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            break
        try:
            if command == "step":
                result = step_shard(core, args[0], args[1], k, obs_size)
                if result[-1] is not None:
                    conn.send(("ok", (None, result[-1])))
                    continue
                obs, reward, terminated, truncated, values, metrics, _ = result
                a["obs"][:], a["reward"][:], a["terminated"][:], a["truncated"][:] = obs, reward, terminated, truncated
                for name, key in info_names:
                    a[name][:] = values[key]
                conn.send(("ok", (metrics, None)))
            elif command == "reset":
                obs, values = reset_shard(core, args[0], k, obs_size)
                a["obs"][:] = obs
                for name, key in info_names:
                    a[name][:] = values[key]
                conn.send(("ok", None))
            elif command == "close":
                break
            else:
                conn.send(("error", f"unknown command {command!r}"))
        except Exception:  # reported to the caller, which raises it
            conn.send(("error", traceback.format_exc()))
    template.close()


def observe(c: BatchCore, k: int, size: int) -> np.ndarray:
    """The kinematics observation of every env of a shard (float32, as the single env's)."""
    own = c.observation(k, size)
    if own is not None:
        return own
    s = c.s
    out = np.empty((c.n, size), dtype=np.float32)
    ego_features(out, s.u, s.yaw, c.guide.road_heading, c.offset, c.lat, c.lane, s.steer_in, s.r)
    base = len(EGO_NAMES)
    vehicles = c.vehicle_slots(k) if k else None
    if vehicles is not None:
        out[:, base : base + vehicles.shape[1]] = vehicles
    elif k:
        out[:, base : base + k * len(VEHICLE_NAMES)] = 0.0
    stim = c._stimulus()
    if stim.shape[1]:
        out[:, base + k * len(VEHICLE_NAMES) :] = stim
    return out
