"""`RecordDrive`: a Gymnasium wrapper that records every episode of an OpenDS env to MCAP.

Why: `opends-gym run ... --record drive.mcap` and training scripts need the same thing:
one replayable file per episode, holding the env id and constructor arguments, the reset
seed and options, and every policy action, next to the World's own recording (see
`DriveRecorder`). Episode files never overwrite anything: `drive.mcap`, `drive(2).mcap`,
... (OpenDS's naming). A reset without a seed gets one drawn by the wrapper (seeded by the
first seed given), so each episode file replays on its own.

Put it directly over the env (gym.make's checker/order/time-limit wrappers are fine): an
action wrapper below it would change the actions between what is recorded and what the
env receives, so that is refused.
"""

from __future__ import annotations

import secrets
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from .recorder import DriveRecorder


def env_description(env: gym.Env[Any, Any]) -> dict[str, Any]:
    """How to build this env again: registered id, entry point and constructor kwargs."""
    base = env.unwrapped
    cls = type(base)
    kwargs = dict(getattr(base, "_ezpickle_kwargs", None) or (env.spec.kwargs if env.spec is not None else {}))
    return {
        "env_id": env.spec.id if env.spec is not None else "",
        "env_entry_point": f"{cls.__module__}:{cls.__qualname__}",
        "env_kwargs": kwargs,
    }


def lct_info(base: Any) -> dict[str, Any] | None:
    """The Lane Change Test's scoring geometry, so the analyzer scores LCT recordings alone."""
    signs = getattr(base, "metric_signs", None)
    basic = getattr(base, "basic", None)
    geometry = getattr(base, "geometry", None)
    if signs is None or basic is None or geometry is None:
        return None
    return {
        "signs": [[s.d_m, s.from_lane, s.to_lane] for s in signs],
        "lane_laterals_m": list(base.lane_laterals),
        "initial_lane": int(base.initial_lane),
        "start_before_sign_m": basic.start_before_sign_m,
        "length_per_lane_m": basic.length_per_lane_m,
        "visibility_m": geometry.visibility_m,
        "start_z_m": float(base.world.task.start_pose.position_m[2]),
        "speed_kmh": geometry.speed_kmh,
        "track_end_m": _lct_track_end(base, float(signs[-1].d_m + geometry.lead_out_m) if signs else 0.0),
    }


def _lct_track_end(base: Any, default: float) -> float:
    """Where the drive ends: 10 m before the end trigger that pauses the simulation."""
    objs = getattr(base.world.objects, "by_id", {}).get("LCT_End_Trigger")
    if not objs:
        return default
    return float(base.world.task.start_pose.position_m[2]) - float(objs[0].position[2]) - 10.0


def _check_no_action_wrappers(env: gym.Env[Any, Any]) -> None:
    e: Any = env
    while isinstance(e, gym.Wrapper):
        if isinstance(e, gym.ActionWrapper):
            raise ValueError(f"RecordDrive must wrap the env below action wrappers ({type(e).__name__} changes the recorded actions)")
        e = e.env


class RecordDrive(gym.Wrapper[Any, Any, Any, Any]):
    """Records each episode to its own MCAP file (see the module docstring).

    `paths` lists the files written so far. Options: `rate_hz` (ego state rate; default
    the physics rate), `follow_recording_actions` (files only between the task's
    startRecording/stopRecording, OpenDS style), `flush_interval_s` (simulated seconds
    between flushes to disk), `fsync`, `foxglove` (Foxglove topics), `meta` (extra metadata
    strings such as the driver's name), `video_rate_hz` (record the driver's view, rendered
    at the env's `render_width` x `render_height`, as `foxglove.CompressedImage` at this
    rate; None: no video) and `video_format` (png or jpeg).
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        path: str | Path,
        *,
        rate_hz: float | None = None,
        follow_recording_actions: bool = False,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        foxglove: bool = True,
        meta: dict[str, Any] | None = None,
        video_rate_hz: float | None = None,
        video_format: str = "png",
    ) -> None:
        super().__init__(env)
        _check_no_action_wrappers(env)
        if not hasattr(env.unwrapped, "world"):
            raise TypeError("RecordDrive records OpenDS envs (the env has no `world`)")
        self.path = Path(path)
        self.options = {
            "rate_hz": rate_hz,
            "follow_recording_actions": follow_recording_actions,
            "flush_interval_s": flush_interval_s,
            "fsync": fsync,
            "foxglove": foxglove,
        }
        self.extra_meta = dict(meta or {})
        if video_rate_hz is not None and not video_rate_hz > 0.0:
            raise ValueError(f"video_rate_hz must be positive, not {video_rate_hz}")
        self.video_rate_hz = video_rate_hz
        self.video_format = video_format
        self._view: Any = None
        self.recorder: DriveRecorder | None = None
        self.paths: list[Path] = []
        self._seed_rng: np.random.Generator | None = None
        self._episodes = 0
        self._description = env_description(env)

    def _choose_seed(self, seed: int | None) -> int:
        if seed is not None:
            self._seed_rng = np.random.default_rng(seed)
            return int(seed)
        if self._seed_rng is None:
            self._seed_rng = np.random.default_rng(secrets.randbits(63))
        return int(self._seed_rng.integers(0, 2**31 - 1))

    def _end_episode(self) -> None:
        if self.recorder is not None:
            self.recorder.close()
            self.paths.extend(p for p in self.recorder.paths if p not in self.paths)
            self.recorder = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        self._end_episode()
        seed = self._choose_seed(seed)
        obs, info = self.env.reset(seed=seed, options=options)
        base: Any = self.env.unwrapped
        meta = {**self._description, "reset_options": options, "episode": self._episodes, "analysis_lct": lct_info(base), **self.extra_meta}
        self._episodes += 1
        video: dict[str, Any] = {}
        if self.video_rate_hz is not None:
            video = {"video_frame": self._driver_view, "video_rate_hz": self.video_rate_hz, "video_format": self.video_format}
        self.recorder = DriveRecorder(base.world, self.path, seed=seed, meta=meta, **self.options, **video)  # type: ignore[arg-type]
        return obs, info

    def _driver_view(self) -> Any:
        """The driver's view of the env's World now (the env's own driver-view renderer)."""
        base: Any = self.env.unwrapped
        if self._view is None:
            from ..render import make_renderer

            self._view = make_renderer("driver_view", base.world)
        return self._view.render(base.config.render_width, base.config.render_height)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        if self.recorder is None:
            raise RuntimeError("call reset() before step()")
        base = self.env.unwrapped
        reset = bool(getattr(base, "pending_reset_position", False))
        self.recorder.log_action(action, engine_key=getattr(base, "pending_engine_key", None), reset_position=reset)
        obs, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            self._end_episode()
        return obs, reward, terminated, truncated, info

    def close(self) -> None:
        self._end_episode()
        super().close()
