"""`DriveRecorder`: a World observer that writes the drive to MCAP in simulation time.

Why: one recorder serves every way of driving a World -- an env (through the `RecordDrive`
wrapper), the human runner, a script. It hangs on `World.observers` and, after each
physics step, writes:

* `/controls` every step (the inputs as applied) and `/actions` (policy actions, given to
  `log_action` by the env wrapper) -- what `replay` feeds back;
* `/ego` (pose, speed, pedals, gear, rpm, fuel, lane, lateral offset, headway/TTC),
  `/traffic`, `/foxglove/ego_pose` (and `/foxglove/traffic`) every `rate_hz` (default:
  every physics step); `/foxglove/scene` at the start and whenever a model changed;
* `/events` (every event of the World's event log) and `/reactions` (scored trials);
* with `foxglove` (default), for Foxglove's 3D panel (`record.foxglove`): `/foxglove/road`
  (road surface and lane lines, once per file), `/tf` (world -> ego and world -> vehicle_N
  every recorded step) and, given `video_frame`, `/foxglove/driver_view` (the driver's view
  as PNG or JPEG every 1 / `video_rate_hz` s). Replay ignores these topics.

Two modes. **always** (`--record`): one file from attach to `close()`. **follow**
(`follow_recording_actions=True`, OpenDS's behaviour): a file opens when the task's
`startRecording` action sets the recording flag and closes at `stopRecording`; the file
name gets OpenDS's `_track<N>` suffix. The inputs since the World's reset are kept in a
backlog and written first into each new file, so every file replays on its own.

A recorder attached to a World that has already stepped (no inputs from the reset) writes
`replayable: false` in its metadata. Writing errors are logged, never raised: a full disk
must not stop a running human session.
"""

from __future__ import annotations

import datetime as _dt
import logging
import platform
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any, Protocol

from ..sim.controls import DriverControls
from ..sim.guide import RoadGuide
from ..sim.world import World
from ..task.model_settings import REACTION_GROUP_COLOURS
from . import foxglove as F  # noqa: N812
from . import messages as M  # noqa: N812
from .mcap_io import McapSink
from .schemas import (
    ACTIONS,
    CONTROLS,
    EGO,
    EVENTS,
    FORMAT,
    FOXGLOVE_POSE,
    FOXGLOVE_ROAD,
    FOXGLOVE_SCENE,
    FOXGLOVE_TF,
    FOXGLOVE_TRAFFIC,
    FOXGLOVE_VIEW,
    REACTIONS,
    TRAFFIC,
)

log = logging.getLogger(__name__)


class Sink(Protocol):
    closed: bool
    path: Path | None
    flushed_messages: int
    flushed_t_ns: int

    def write(self, topic: str, t_ns: int, msg: dict[str, Any]) -> None: ...

    def flush(self, t_ns: int | None = None) -> None: ...

    def flush_if_due(self, t_ns: int) -> None: ...

    def close(self) -> None: ...


SinkFactory = Callable[[dict[str, Any], str, int], Sink]  # (metadata, file-name tag, start ns) -> sink


def software_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        ours = version("opends_gym")
    except PackageNotFoundError:  # running from a source tree
        from ..version import __version__ as ours
    try:
        mcap_v = version("mcap")
    except PackageNotFoundError:  # pragma: no cover
        mcap_v = "?"
    return f"opends_gym {ours}; mcap {mcap_v}; python {platform.python_version()}"


def task_identity(world: World) -> dict[str, str]:
    """Task name, where it was loaded from and a hash pinning its content."""
    task = world.task
    entry = task.folder / task.entry.file_name if task.entry.file_name else task.folder
    if task.entry.file_name and entry.is_file():
        return {"task_name": task.name, "task_path": str(entry.resolve()), "task_sha256": task.files_sha256(), "task_hash_of": "files"}
    import hashlib

    # generated in memory (the Lane Change Test): hash the task's content instead
    return {
        "task_name": task.name,
        "task_path": "",
        "task_sha256": hashlib.sha256(repr(task).encode()).hexdigest(),
        "task_hash_of": "content",
    }


def guide_info(guide: RoadGuide) -> dict[str, Any]:
    out: dict[str, Any] = {
        "kind": guide.kind,
        "start_xz": list(guide.start_xz),
        "start_yaw": guide.start_yaw,
        "lane_laterals_m": list(guide.lane_laterals_m),
        "lane_ids": list(guide.lane_ids),
        "lane_width_m": guide.lane_width_m,
    }
    if guide.kind == "lanes":
        out["sign"] = guide.sign
    if guide.polyline is not None:
        out["polyline"] = guide.polyline.xz.tolist()
    return out


def analysis_info(world: World, guide: RoadGuide) -> dict[str, Any]:
    """What the analyzer needs without loading the task: lanes, ideal tracks, reaction colours."""
    groups = world.task.settings.reaction_groups
    return {
        "lanes": [{"id": b.id, "x_min_m": b.x_min, "x_max_m": b.x_max} for b in world.road.lanes],
        "ideal_tracks": {
            tid: {"points": poly.xz.tolist(), "road_width_m": width} for tid, (poly, width) in world.road.ideal_tracks.items()
        },
        "reaction_groups": {getattr(groups, c): c for c in REACTION_GROUP_COLOURS if getattr(groups, c)},
        "guide": guide_info(guide),
    }


class DriveRecorder:
    """Records one World (see the module docstring). Attach right after `World.reset()`."""

    def __init__(
        self,
        world: World,
        path: str | Path | None = None,
        *,
        follow_recording_actions: bool = False,
        rate_hz: float | None = None,
        seed: int | None = None,
        meta: dict[str, Any] | None = None,
        flush_interval_s: float = 1.0,
        fsync: bool = False,
        foxglove: bool = True,
        sink_factory: SinkFactory | None = None,
        video_frame: Callable[[], Any] | None = None,
        video_rate_hz: float = 10.0,
        video_format: str = "png",
    ) -> None:
        if path is None and sink_factory is None:
            raise ValueError("DriveRecorder needs a path or a sink_factory")
        if video_frame is not None and not video_rate_hz > 0.0:
            raise ValueError(f"video_rate_hz must be positive, not {video_rate_hz}")
        if video_format not in F.IMAGE_FORMATS:
            raise ValueError(f"video_format must be png or jpeg, not {video_format!r}")
        self.video_frame = video_frame
        self.video_format = video_format
        self.video_every = max(1, int(round(1.0 / (world.dt_s * video_rate_hz))))
        self.world = world
        self.base_path = Path(path) if path is not None else None
        self.follow = follow_recording_actions
        physics_hz = 1.0 / world.dt_s
        if rate_hz is not None and rate_hz <= 0.0:
            raise ValueError(f"rate_hz must be positive, not {rate_hz}")
        self.every = max(1, int(round(physics_hz / rate_hz))) if rate_hz else 1
        self.flush_interval_s = flush_interval_s
        self.fsync = fsync
        self.foxglove = foxglove
        self._factory = sink_factory or self._file_sink
        self.guide = RoadGuide(world)
        self.seed = seed
        self.extra_meta = dict(meta or {})
        self.replayable = world.step_count == 0
        self.start_step = world.step_count
        self.sink: Sink | None = None
        self.segment = 0
        self.paths: list[Path] = []
        self.failed = ""
        self._backlog: list[tuple[str, int, dict[str, Any]]] = []
        self._event_cursor = 0 if world.step_count == 0 else len(world.events)
        self._reaction_cursor = 0
        self._action_index = 0
        self._last_step = world.step_count
        self._scene_sig: Any = None
        self._was_recording = False
        self._closed = False
        world.observers.append(self)
        if not self.follow:
            self._open(track=None)

    # ------------------------------------------------------------------ files
    def metadata(self, track: int | None) -> dict[str, Any]:
        w = self.world
        meta: dict[str, Any] = {
            "format": FORMAT,
            "software_version": software_version(),
            "created_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
            **task_identity(w),
            "seed": self.seed,
            "world_config": asdict(w.config),
            "physics_hz": 1.0 / w.dt_s,
            "ego_rate_hz": 1.0 / (w.dt_s * self.every),
            "mode": "follow" if self.follow else "always",
            "segment": self.segment,
            "track": track,
            "start_step": w.step_count,
            "replayable": self.replayable,
            "analysis": analysis_info(w, self.guide),
        }
        meta.update(self.extra_meta)
        return meta

    def _file_sink(self, meta: dict[str, Any], tag: str, start_ns: int) -> Sink:
        assert self.base_path is not None
        return McapSink(self.base_path, meta, start_ns=start_ns, flush_interval_s=self.flush_interval_s, fsync=self.fsync, suffix_tag=tag)

    def _open(self, track: int | None) -> None:
        self.segment += 1
        tag = f"_track{track}" if self.follow and track is not None else ""
        try:
            self.sink = self._factory(self.metadata(track), tag, M.sim_ns(self.world.t_s))
        except OSError as e:
            self._fail(e)
            return
        if self.sink.path is not None:
            self.paths.append(self.sink.path)
        for topic, t_ns, msg in self._backlog:
            self._write(topic, t_ns, msg)
        if self.foxglove:
            self._scene_sig = None
            self._publish_scene()
            self._write(FOXGLOVE_ROAD, M.sim_ns(self.world.t_s), F.road_scene(self.world, self.guide))

    def _close_segment(self) -> None:
        if self.sink is not None:
            try:
                self.sink.close()
            except OSError as e:
                self._fail(e)
            self.sink = None

    def _fail(self, e: Exception) -> None:
        self.failed = f"{type(e).__name__}: {e}"
        log.error("drive recording stopped: %s", self.failed)
        self.sink = None

    def _write(self, topic: str, t_ns: int, msg: dict[str, Any]) -> None:
        if self.sink is None:
            return
        try:
            self.sink.write(topic, t_ns, msg)
        except OSError as e:
            self._fail(e)

    @property
    def path(self) -> Path | None:
        """The file being written, or the last one written."""
        return self.paths[-1] if self.paths else None

    @property
    def recording(self) -> bool:
        return self.sink is not None

    # ------------------------------------------------------------------ inputs
    def log_action(self, action: Any, engine_key: bool | None = None, reset_position: bool = False) -> None:
        """A policy action about to be passed to env.step() (called by `RecordDrive`), with the
        ignition key the driver turned for that step (`OpenDSEnv.turn_engine_key`), if any,
        and whether the car is reset to its last lane position with it (`OpenDSEnv.reset_position`)."""
        msg = M.action_message(self.world.t_s, self._action_index, action)
        if engine_key is not None:
            msg["engine_key"] = bool(engine_key)
        if reset_position:
            msg["reset_position"] = True
        self._action_index += 1
        t_ns = M.sim_ns(self.world.t_s)
        if self.follow:
            self._backlog.append((ACTIONS, t_ns, msg))
        self._write(ACTIONS, t_ns, msg)

    def world_reset(self, seed: int | None = None) -> None:
        """The World was reset: end the current file, start over (always mode: a new file)."""
        self._close_segment()
        self._backlog.clear()
        self._event_cursor = 0
        self._reaction_cursor = 0
        self._action_index = 0
        self._last_step = self.world.step_count
        self._was_recording = False
        self.seed = seed
        self.replayable = self.world.step_count == 0
        if not self.follow and not self._closed:
            self._open(track=None)

    # ------------------------------------------------------------------ the observer
    def __call__(self, world: World, c: DriverControls) -> None:
        if self._closed:
            return
        if world.step_count <= self._last_step:  # reset behind our back: the seed is unknown
            self.world_reset(None)
            self.replayable = False
        self._last_step = world.step_count
        t_ns = M.sim_ns(world.t_s)
        ctrl = M.controls_message(world, c)
        if self.follow:
            self._backlog.append((CONTROLS, t_ns, ctrl))
            now = bool(getattr(world.triggers, "recording", False))
            if now and not self._was_recording and not self.failed:
                self._open(track=getattr(world.triggers, "recording_track", None))
            else:
                self._write(CONTROLS, t_ns, ctrl)
            stopping = self._was_recording and not now
            self._was_recording = now
        else:
            self._write(CONTROLS, t_ns, ctrl)
            stopping = False
        new_events = world.events.since(self._event_cursor)
        self._event_cursor = len(world.events)
        reactions = world.triggers.reactions
        new_reactions = reactions[self._reaction_cursor :]
        self._reaction_cursor = len(reactions)
        if self.sink is None:
            return
        if not stopping and world.step_count % self.every == 0:
            self._write(EGO, t_ns, M.ego_message(world, self.guide))
            traffic = M.traffic_message(world)
            if traffic is not None:
                self._write(TRAFFIC, t_ns, traffic)
            if self.foxglove:
                self._write(FOXGLOVE_POSE, t_ns, M.foxglove_pose(world))
                self._write(FOXGLOVE_TF, t_ns, F.frame_transforms(world, traffic))
                if traffic is not None:
                    self._write(FOXGLOVE_TRAFFIC, t_ns, M.foxglove_traffic(world, traffic))
        if not stopping and self.video_frame is not None and world.step_count % self.video_every == 0:
            self._write(FOXGLOVE_VIEW, t_ns, F.compressed_image(world.t_s, self.video_frame(), self.video_format))
        for ev in new_events:
            self._write(EVENTS, M.sim_ns(ev.t_s), M.event_message(ev))
        for r in new_reactions:
            self._write(REACTIONS, M.sim_ns(r.t_s), M.reaction_message(r))
        if self.foxglove and new_events:
            self._publish_scene()
        if stopping:
            self._close_segment()
        elif self.sink is not None:
            try:
                self.sink.flush_if_due(t_ns)
            except OSError as e:
                self._fail(e)

    def _publish_scene(self) -> None:
        sig = M.scene_signature(self.world)
        if sig != self._scene_sig:
            self._scene_sig = sig
            self._write(FOXGLOVE_SCENE, M.sim_ns(self.world.t_s), M.foxglove_scene(self.world))

    # ------------------------------------------------------------------ end
    def flush(self) -> None:
        """Push everything recorded so far to the OS now."""
        if self.sink is not None:
            try:
                self.sink.flush(M.sim_ns(self.world.t_s))
            except OSError as e:
                self._fail(e)

    def close(self) -> None:
        """Finish the file (summary, footer) and stop observing the World."""
        if self._closed:
            return
        self._closed = True
        self._close_segment()
        if self in self.world.observers:
            self.world.observers.remove(self)

    def __enter__(self) -> DriveRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def attach_recorder(world: World, path: str | Path, **options: Any) -> DriveRecorder:
    """Record a World driven directly (human sessions, scripts). See `DriveRecorder`."""
    return DriveRecorder(world, path, **options)
