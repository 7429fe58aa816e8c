"""Exact replay: re-simulate a recording from its task, seed and inputs, and check it.

Why: a recording is only evidence if the drive can be reproduced. `replay` rebuilds the
env (recorded id, entry point and constructor kwargs) and resets it with the recorded seed
and options -- or, for a World driven directly (human sessions), loads the recorded task
and config -- then feeds the recorded policy actions (or `/controls`). A second
`DriveRecorder` with an in-memory sink, configured like the original, rebuilds every
message, and the state topics (`/ego`, `/controls`, `/traffic`, `/events`, `/reactions`)
are compared as JSON text: bit-exact floats (-0.0 differs from 0.0). A file cut short by a
crash must be a prefix of the replay.

`replay_to(path, t_s)` stops at a simulation time and hands back the World (and env), as
it was then, for the viewer or for inspection.
"""

from __future__ import annotations

import importlib
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..sim.world import World, WorldConfig
from . import messages as M  # noqa: N812
from .mcap_io import MemorySink, Recording, read_recording
from .recorder import DriveRecorder, Sink, task_identity
from .schemas import ACTIONS, CHECKED_TOPICS, CONTROLS

log = logging.getLogger(__name__)
EPS_S = 1e-9


class ReplayError(RuntimeError):
    """The recording cannot be replayed (names the file and the reason)."""


@dataclass(frozen=True)
class Mismatch:
    topic: str
    index: int  # message number on that topic (0-based)
    t_s: float
    field: str  # first differing field ('' for a missing/extra message)
    recorded: Any
    replayed: Any

    def __str__(self) -> str:
        where = f"{self.topic} message #{self.index} (t = {self.t_s:.6f} s)"
        if not self.field:
            return f"{where}: recorded {self.recorded!s}, replay {self.replayed!s}"
        return f"{where}, field '{self.field}': recorded {self.recorded!r}, replayed {self.replayed!r}"


@dataclass
class ReplayResult:
    recording: Recording
    world: World
    env: Any = None  # the gymnasium env (None for World-level recordings)
    inputs_fed: int = 0
    checked: dict[str, int] = field(default_factory=dict)  # topic -> messages compared
    mismatch: Mismatch | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.mismatch is None

    def close(self) -> None:
        if self.env is not None:
            self.env.close()
        else:
            self.world.close()


def _build_env(meta: dict[str, Any]) -> Any:
    entry = str(meta.get("env_entry_point") or "")
    kwargs = dict(meta.get("env_kwargs") or {})
    kwargs["render_mode"] = None  # rendering never changes the simulation
    if entry:
        module, _, name = entry.partition(":")
        try:
            cls = getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError) as e:
            raise ReplayError(f"cannot import the recorded env {entry}: {e}") from e
        return cls(**kwargs)
    import gymnasium as gym

    from ..envs.registration import register_envs

    register_envs()

    return gym.make(str(meta["env_id"]), **kwargs).unwrapped


def _build(rec: Recording) -> tuple[Any, World, list[str]]:
    meta = rec.meta
    warnings: list[str] = []
    if meta.get("replayable") is False:
        raise ReplayError(
            f"{rec.path}: not replayable (the recorder was attached after the World had stepped,"
            " or the World was reset without a known seed)"
        )
    seed = meta.get("seed")
    if meta.get("env_entry_point") or meta.get("env_id"):
        env = _build_env(meta)
        env.reset(seed=seed, options=meta.get("reset_options"))
        world = env.unwrapped.world
    else:
        task_path = meta.get("task_path") or ""
        if not task_path:
            raise ReplayError(f"{rec.path}: a World-level recording of a generated task cannot be replayed (no task path)")
        if seed is None:
            warnings.append("the recording has no seed; a task that draws random numbers will not replay exactly")
        try:
            config = WorldConfig(**(meta.get("world_config") or {}))
            world = World(task_path, config, seed=seed)
        except (OSError, ValueError, TypeError) as e:
            raise ReplayError(f"{rec.path}: cannot rebuild the World from {task_path}: {e}") from e
        env = None
    ident = task_identity(world)
    if meta.get("task_sha256") and ident["task_sha256"] != meta["task_sha256"]:
        warnings.append(
            f"the task changed since recording (sha256 {meta['task_sha256'][:12]}... recorded, {ident['task_sha256'][:12]}... now)"
        )
    return env, world, warnings


def _first_difference(a: Any, b: Any, prefix: str = "") -> tuple[str, Any, Any]:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if M.encode({"v": a.get(k)}) != M.encode({"v": b.get(k)}):
                return _first_difference(a.get(k), b.get(k), f"{prefix}{k}.")
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            if M.encode({"v": x}) != M.encode({"v": y}):
                return _first_difference(x, y, f"{prefix}{i}.")
    return prefix.rstrip("."), a, b


def compare(
    recorded: Recording, replayed: list[tuple[str, int, Any]], until_ns: int | None = None
) -> tuple[dict[str, int], Mismatch | None]:
    """Compare the state topics message by message (bit-exact JSON)."""
    by_topic: dict[str, list[tuple[int, Any]]] = {}
    for topic, t_ns, msg in replayed:
        by_topic.setdefault(topic, []).append((t_ns, msg))
    counts: dict[str, int] = {}
    first: Mismatch | None = None
    for topic in CHECKED_TOPICS:
        rec_msgs = [m for m in recorded.messages.get(topic, []) if until_ns is None or m[0] <= until_ns]
        new_msgs = [m for m in by_topic.get(topic, []) if until_ns is None or m[0] <= until_ns]
        counts[topic] = 0
        mismatch = None
        for i, (t_ns, msg) in enumerate(rec_msgs):
            if i >= len(new_msgs):
                mismatch = Mismatch(topic, i, t_ns / 1e9, "", "a message", "none (the replay ended earlier)")
                break
            nt, nmsg = new_msgs[i]
            if nt != t_ns or M.encode(msg) != M.encode(nmsg):
                name, a, b = _first_difference(msg, nmsg)
                mismatch = Mismatch(topic, i, t_ns / 1e9, name or "log_time", a if name else t_ns, b if name else nt)
                break
            counts[topic] += 1
        if mismatch is None and recorded.complete and until_ns is None and len(new_msgs) > len(rec_msgs):
            mismatch = Mismatch(
                topic, len(rec_msgs), new_msgs[len(rec_msgs)][0] / 1e9, "", "no more messages", f"{len(new_msgs) - len(rec_msgs)} more"
            )
        if mismatch is not None and (first is None or mismatch.t_s < first.t_s):
            first = mismatch
    return counts, first


def replay(path: str | Path | Recording, *, check: bool = True, until_s: float | None = None) -> ReplayResult:
    """Re-simulate a recording (up to `until_s`), comparing it with the file when `check`."""
    rec = path if isinstance(path, Recording) else read_recording(path)
    meta = rec.meta
    env, world, warnings = _build(rec)
    segments: list[MemorySink] = []

    def memory(meta_: dict[str, Any], tag: str, start_ns: int) -> Sink:
        segments.append(MemorySink())
        return segments[-1]

    checker = DriveRecorder(
        world,
        follow_recording_actions=meta.get("mode") == "follow",
        rate_hz=meta.get("ego_rate_hz"),
        seed=meta.get("seed"),
        foxglove=False,
        sink_factory=memory,
    )
    result = ReplayResult(rec, world, env, warnings=warnings)
    try:
        if env is not None:
            actions = rec.topic(ACTIONS)
            if not actions and rec.topic(CONTROLS):
                raise ReplayError(f"{rec.path}: an env recording without /actions cannot be replayed")
            for msg in actions:
                if until_s is not None and world.t_s >= until_s - EPS_S:
                    break
                if msg.get("engine_key") is not None:  # the ignition key turned with this action
                    env.unwrapped.turn_engine_key(bool(msg["engine_key"]))
                if msg.get("reset_position"):  # the car was reset to its last lane position with this action
                    env.unwrapped.reset_position()
                _, _, terminated, truncated, _ = env.step(M.action_from_message(msg))
                result.inputs_fed += 1
                if terminated or truncated:
                    break
        else:
            for msg in rec.topic(CONTROLS):
                if until_s is not None and world.t_s >= until_s - EPS_S:
                    break
                world.step(M.controls_from_message(msg))
                result.inputs_fed += 1
    finally:
        checker.close()
    if check:
        index = int(meta.get("segment") or 1) - 1
        replayed = segments[index].messages if index < len(segments) else []
        until_ns = M.sim_ns(world.t_s) if until_s is not None else None
        result.checked, result.mismatch = compare(rec, replayed, until_ns)
    return result


def replay_to(path: str | Path | Recording, t_s: float) -> ReplayResult:
    """The World (and env) as it was at simulation time `t_s` of the recording."""
    if t_s < 0:
        raise ValueError("the time must be >= 0")
    return replay(path, check=True, until_s=t_s)


def describe_state(world: World) -> dict[str, Any]:
    """A readable snapshot of the World (for `replay --at`)."""
    from ..sim.guide import RoadGuide

    ego = M.ego_message(world, RoadGuide(world))
    keep = (
        "t_s",
        "step",
        "x_m",
        "y_m",
        "z_m",
        "yaw_rad",
        "speed_kmh",
        "steering",
        "accelerator",
        "brake",
        "gear",
        "rpm",
        "fuel_used_l",
        "lane",
        "lane_offset_m",
        "headway_s",
        "collisions",
        "paused",
        "recording",
    )
    out = {k: ego[k] for k in keep}
    out["events"] = len(world.events)
    out["reactions"] = len(world.triggers.reactions)
    last = world.triggers.reactions[-1] if world.triggers.reactions else None
    out["last_reaction"] = None if last is None else f"{last.group} {last.timer_id}: result {last.result}, {last.reaction_time_s:.3f} s"
    out["traffic_vehicles"] = len(getattr(world.traffic, "ids", ())) if world.traffic is not None else 0
    return out
