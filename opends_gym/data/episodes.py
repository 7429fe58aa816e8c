"""A recorded drive as one episode of an env, stepped at the env's policy rate.

Why replay: a dataset's observations, rewards and info metrics must be exactly what the env gives
for those actions, so every drive is driven again through the env (`gymnasium.make`, so the env
spec travels with the dataset):

* an env recording (`opends-gym run`; `opends-gym drive` and a study's human blocks, whose
  sessions step the same env at the session's policy rate) holds the actions (`/actions`): fed
  as `record.replay` feeds them (ignition key and position resets included), from the
  recorded seed and reset options: the episode is the recorded one, step for step;
* a World-level recording (a `World` driven directly, without an env) holds `/controls` at the
  physics rate, and an OpenDS `carData.txt` holds steering, gas and brake at its own rate (OpenDS's
  `DataWriter`, rows 50 ms or more apart, wall-clock stamped): the inputs held at the start of
  each policy step (zero-order hold, as the drive was) become a continuous action
  `[steering, gas - brake]` (OpenDS's steering sign, + left; brake wins where both are
  pressed, as a negative pedal). carData time is OpenDS's simulated time (`record.conform`'s
  `Recorded.sim_t`), its "accelerate back" key becomes braking (our continuous action has no
  reverse). A World-level recording starts at the task's start; a carData log starts in its own
  first settled state (`Recorded.settled_row`: steering centred or the car standing, so no yaw
  rate the log lacks is under way; with `trim_idle` the first such row from the first gas with
  the engine running), through the env's `start_pose` reset option (`envs.start_pose`): pose,
  speed and engine as logged; where the log's engine state changes, the ignition key is turned. Either is
  an approximation of the person's drive: the actions are theirs, the states the env's.

A drive that ends before the env ends the episode is marked truncated at its last step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..envs.registration import register_envs, resolve_env_id
from ..errors import UserError

INPUT_ACTION = "continuous"  # the action type person drives and OpenDS logs are mapped onto


class NeverSetsOff(UserError):
    """A drive trimmed at its first gas (`trim_idle`) that never gives gas: nothing of it is
    driving, and its standing would teach a clone to stand (`opends-gym export` skips it)."""


@dataclass
class Episode:
    """One drive as env steps: T actions, T+1 observations and info rows (reset first)."""

    source: str  # the file it came from
    kind: str  # actions | controls | cardata
    seed: int | None
    observations: list[Any] = field(default_factory=list)
    actions: list[Any] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    terminations: list[bool] = field(default_factory=list)
    truncations: list[bool] = field(default_factory=list)
    infos: dict[str, list[float]] = field(default_factory=dict)
    metrics: dict[str, float] = field(default_factory=dict)  # the env's episode_metrics (scalars)
    start_pose: dict[str, float] | None = None  # the reset's start_pose option (envs.start_pose), if any
    env_spec: Any = None  # gymnasium EnvSpec of the env it was driven through
    observation_space: Any = None
    action_space: Any = None

    @property
    def steps(self) -> int:
        return len(self.actions)


def _scalar(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def scalar_metrics(metrics: dict[str, Any]) -> dict[str, float]:
    """The numeric entries of an `episode_metrics` dict (bools as 0/1)."""
    return {k: float(v) for k, v in metrics.items() if _scalar(v) or isinstance(v, (bool, np.bool_))}


def make_env(env_id: str, kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    """The env by registered id through `gymnasium.make`, so its spec can rebuild it."""
    register_envs()
    return gym.make(env_id, **kwargs)


def _start(env: gym.Env[Any, Any], source: str, kind: str, seed: int | None, obs: Any, info: dict[str, Any]) -> Episode:
    """An episode holding the reset's observation and numeric info keys (the keys every step records)."""
    keys = [k for k, v in info.items() if _scalar(v)]
    ep = Episode(source, kind, seed, [obs], infos={k: [float(info[k])] for k in keys})
    ep.env_spec, ep.observation_space, ep.action_space = env.spec, env.observation_space, env.action_space
    return ep


def _step(env: gym.Env[Any, Any], ep: Episode, action: Any) -> tuple[Any, dict[str, Any], bool]:
    """Step `env`, append the step to `ep`; returns the observation, info and whether the episode ended."""
    obs, reward, terminated, truncated, info = env.step(action)
    ep.observations.append(obs)
    ep.actions.append(action)
    ep.rewards.append(float(reward))
    ep.terminations.append(bool(terminated))
    ep.truncations.append(bool(truncated))
    for k, values in ep.infos.items():
        v = info.get(k, math.nan)
        values.append(float(v) if _scalar(v) else math.nan)
    if terminated or truncated:
        ep.metrics = scalar_metrics(info.get("episode_metrics", {}))
    return obs, info, bool(terminated or truncated)


def drive(env: gym.Env[Any, Any], source: str, kind: str, seed: int | None, options: Any, actions: Any) -> Episode:
    """Reset `env` and step it with `actions` (an iterable of actions or of (action, hooks)) until
    the episode or the actions end."""
    obs, info = env.reset(seed=seed, options=options)
    ep = _start(env, source, kind, seed, obs, info)
    if options and options.get("start_pose") is not None:
        ep.start_pose = {k: float(v) for k, v in options["start_pose"].items()}
    base: Any = env.unwrapped
    for item in actions:
        action, hooks = item if isinstance(item, tuple) else (item, {})
        if hooks.get("engine_key") is not None:
            base.turn_engine_key(bool(hooks["engine_key"]))
        if hooks.get("reset_position"):
            base.reset_position()
        if _step(env, ep, action)[2]:
            break
    if not ep.actions:
        raise UserError(f"{source}: the drive has no input to step the env with")
    if not (ep.terminations[-1] or ep.truncations[-1]):
        ep.truncations[-1] = True  # the drive ended here, the env had not
    return ep


def collect(env: gym.Env[Any, Any], agent: Any, seed: int) -> Episode:
    """One episode of `agent` (drivers.agents) on `env`, as `drive` would have recorded it."""
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed)
    ep = _start(env, f"agent {getattr(agent, 'name', agent)}", "agent", seed, obs, info)
    box = env.action_space if isinstance(env.action_space, gym.spaces.Box) else None
    done = False
    while not done:
        action = agent.act(obs, info)
        obs, info, done = _step(env, ep, np.asarray(action, dtype=box.dtype) if box is not None else action)
    return ep


def _recorded_actions(rec: Any) -> list[tuple[Any, dict[str, Any]]]:
    from ..record import messages as M  # noqa: N812
    from ..record.schemas import ACTIONS

    out = []
    for msg in rec.topic(ACTIONS):
        hooks = {"engine_key": msg.get("engine_key"), "reset_position": msg.get("reset_position")}
        out.append((M.action_from_message(msg), hooks))
    return out


def _policy_hz(env: gym.Env[Any, Any]) -> float:
    base: Any = env.unwrapped
    return float(base.config.policy_hz)


def held_rows(t_s: np.ndarray, policy_hz: float) -> np.ndarray:
    """The sample in force at each policy step's start (each held to the next sample): one per
    policy step from t = 0 to the last sample."""
    t = np.asarray(t_s, dtype=float) - float(t_s[0])
    n = int(math.floor(t[-1] * policy_hz + 1e-9)) + 1
    rows = np.searchsorted(t, np.arange(n) / policy_hz + 1e-9, side="right") - 1
    return np.clip(rows, 0, len(t) - 1)


def held_inputs(t_s: np.ndarray, steering: np.ndarray, pedal: np.ndarray, policy_hz: float) -> list[np.ndarray]:
    """Continuous actions at the policy rate from inputs sampled at `t_s` (`held_rows`)."""
    return [np.asarray([np.clip(steering[i], -1, 1), np.clip(pedal[i], -1, 1)], dtype=np.float32) for i in held_rows(t_s, policy_hz)]


def engine_keys(engine_on: np.ndarray, rows: np.ndarray) -> list[dict[str, Any]]:
    """`drive` hooks turning the ignition key at the policy steps where a log's engine state
    changes (a person who starts the engine before setting off; OpenDS logs it per row)."""
    on = np.asarray(engine_on, dtype=float)[rows] > 0.5
    return [{"engine_key": bool(on[k])} if k and on[k] != on[k - 1] else {} for k in range(len(rows))]


def _input_env(env_id: str | None, task: str | None, source: str, env_kwargs: dict[str, Any]) -> gym.Env[Any, Any]:
    if env_id is None and task is None:
        raise UserError(f"{source}: say which env it drives: --env ENV_ID (or the task with --task)")
    if env_id is None:
        target, kwargs = "OpenDS/DrivingTask-v0", {"task": str(Path(str(task)).resolve())}
    else:
        target, kwargs = resolve_env_id(env_id)
        if "task" in kwargs:
            kwargs["task"] = str(Path(kwargs["task"]).resolve())
        elif task is not None and target == "OpenDS/DrivingTask-v0":
            kwargs["task"] = str(Path(str(task)).resolve())
    env = make_env(target, {**kwargs, **env_kwargs, "action": INPUT_ACTION})
    return env


def from_recording(
    path: str | Path, env_id: str | None = None, env_kwargs: dict[str, Any] | None = None, trim_idle: bool = False
) -> Episode:
    """An MCAP recording: its actions through its own env, or its controls through `env_id`."""
    from ..record.mcap_io import read_recording
    from ..record.schemas import ACTIONS, CONTROLS

    p = Path(path)
    rec = read_recording(p, topics=(ACTIONS, CONTROLS))
    meta = rec.meta
    if meta.get("env_id") and rec.topic(ACTIONS):
        recorded = str(meta["env_id"])
        if env_id is not None and resolve_env_id(env_id)[0] != recorded:
            raise UserError(f"{p}: recorded on {recorded}, its actions do not fit {env_id} (leave --env out)")
        kwargs = {**dict(meta.get("env_kwargs") or {}), **(env_kwargs or {}), "render_mode": None}
        env = make_env(recorded, kwargs)
        try:
            return drive(env, str(p), "actions", meta.get("seed"), meta.get("reset_options"), _recorded_actions(rec))
        finally:
            env.close()
    controls = rec.topic(CONTROLS)
    if not controls:
        raise UserError(f"{p}: the recording holds neither /actions nor /controls")
    t = np.asarray([float(m["t_s"]) for m in controls])
    steer = np.asarray([float(m.get("steering", 0.0)) for m in controls])
    pedal = np.asarray([float(m.get("accelerator", 0.0)) - float(m.get("brake", 0.0)) for m in controls])
    i0 = _set_off(pedal, str(p)) if trim_idle else 0
    env = _input_env(env_id, meta.get("task_path") or None, str(p), env_kwargs or {})
    try:
        hz = _policy_hz(env)
        return drive(env, str(p), "controls", meta.get("seed"), None, held_inputs(t[i0:], steer[i0:], pedal[i0:], hz))
    finally:
        env.close()


def first_gas(pedal: np.ndarray) -> int:
    """The first sample where the driver gives gas, sets off (0 when they never do)."""
    gas = np.flatnonzero(pedal > 0.0)
    return int(gas[0]) if gas.size else 0


def _set_off(pedal: np.ndarray, source: str) -> int:
    """`first_gas` for `trim_idle`; NeverSetsOff when the driver never gives gas."""
    if not np.any(pedal > 0.0):
        raise NeverSetsOff(f"{source}: never gives gas, nothing is left after trimming the idle start")
    return first_gas(pedal)


def cardata_start_pose(rec: Any, i: int) -> dict[str, Any]:
    """The `start_pose` reset option for a carData log's row i (`record.conform.Recorded`)."""
    return {
        "x": float(rec.x[i]),
        "y": float(rec.y[i]),
        "z": float(rec.z[i]),
        "yaw_rad": float(rec.yaw[i]),
        "speed_mps": max(0.0, float(rec.speed_kmh[i]) / 3.6),
        "engine_on": bool(rec.engine_on[i]),
    }


def cardata_pedal(rec: Any) -> np.ndarray:
    """A carData log's pedal per row as the continuous action's: gas, or minus the brake where it is pressed."""
    return np.where(rec.brake > 0.0, -rec.brake, np.maximum(rec.gas, 0.0))


def cardata_start_row(rec: Any, trim_idle: bool) -> int:
    """The row a carData log's episode starts at: its first settled row (`Recorded.settled_row`;
    the first row where it has none), with `trim_idle` from the first gas given with the engine
    running (gas with the engine off moves nothing: OpenDS's `Car.setEngineOn`); NeverSetsOff
    where there is none."""
    first = 0
    if trim_idle:
        first = _set_off(np.where(np.asarray(rec.engine_on) > 0.5, cardata_pedal(rec), 0.0), str(rec.path))
    row = rec.settled_row(first)
    # a wheel (not keys) is seldom exactly centred: a log that is moving and steering all along has
    # no settled row; it starts at its first (a yaw rate it lacks dies out within ~0.1 s) rather than its last
    return first if row == rec.n - 1 and first < rec.n - 1 else row


def from_cardata(
    path: str | Path, env_id: str | None, task: str | None, env_kwargs: dict[str, Any] | None = None, trim_idle: bool = False
) -> Episode:
    """An OpenDS carData.txt: its steering, gas and brake through `env_id` (or the task's generic env).
    The episode starts in the log's first settled state (module docstring); `trim_idle` starts
    at the first gas (a log that waits at the start, steering or not, teaches a clone to wait;
    one that never gives gas raises NeverSetsOff)."""
    from ..record.conform import Recorded

    p = Path(path)
    rec = Recorded(p)
    i0 = cardata_start_row(rec, trim_idle)
    env = _input_env(env_id, task, str(p), env_kwargs or {})
    try:
        steps = cardata_steps(rec, i0, _policy_hz(env))
        return drive(env, str(p), "cardata", None, {"start_pose": cardata_start_pose(rec, i0)}, steps)
    finally:
        env.close()


def cardata_steps(rec: Any, i0: int, policy_hz: float) -> list[tuple[np.ndarray, dict[str, Any]]]:
    """A carData log's (action, hooks) per policy step from row i0 (`drive`'s input): the inputs
    held at each step's start and the ignition key where the log's engine state changes."""
    pedal = cardata_pedal(rec)
    rows = i0 + held_rows(rec.sim_t[i0:], policy_hz)
    actions = [np.asarray([np.clip(rec.steering[i], -1, 1), np.clip(pedal[i], -1, 1)], dtype=np.float32) for i in rows]
    return list(zip(actions, engine_keys(rec.engine_on, rows), strict=True))


def load_episode(
    path: str | Path, env_id: str | None = None, task: str | None = None, env_kwargs: dict[str, Any] | None = None, trim_idle: bool = False
) -> Episode:
    """Any drive file: MCAP (by its magic bytes) or an OpenDS carData.txt; `trim_idle` drops a person's
    or log's samples before the first gas (env recordings are replayed whole)."""
    from ..record.mcap_walk import MAGIC

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such drive")
    with p.open("rb") as f:
        magic = f.read(len(MAGIC))
    if magic == MAGIC:
        return from_recording(p, env_id, env_kwargs, trim_idle)
    return from_cardata(p, env_id, task, env_kwargs, trim_idle)
