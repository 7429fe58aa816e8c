"""`DriveSession`: a person drives an OpenDS env in real time; the experimenter gets the
same metrics and the same recording as from an agent's run.

Why this shape: the session steps the very env an agent would use (`gym.make` of the
task's env id) with the `controls` action type at `policy_hz = physics_hz`, so every
physics step is one `env.step` and `info`/`episode_metrics` are computed by the same
code. The action passed (and recorded by `RecordDrive`) is the encoded `DriverControls`
of that step, so `opends-gym replay` re-simulates a human session bit for bit, like any
agent's.

Loop: pump window/joystick events; unless held, run the physics steps the wall clock says
are due (`PacingClock`), each with the merged input of every source; after each step,
publish a `VehicleSnapshot` (settings controller, CAN feedback, external visualization),
play and log sounds; draw one frame. Holds -- pause (toggle_pause), an instruction screen
(closed by Return, Space or the close_instruction_screen key/button), an unplugged wheel
-- stop the steps, not the loop. An instruction screen is held by the runner, not by the
World: the World closes it at once (its default), so the simulation is the agent's
simulation and the screen costs no simulated time. Without a window nobody can read it,
so it is not held. Leaving the road or colliding never ends the drive (the env runs with
`on_road_exit="continue"` and `terminate_on_collision=False`, as OpenDS, unless
`env_kwargs` say otherwise): the participant steers back, or the car is put back on its
last lane position (`reset_position`: the `reset_position` command of any source -- the
settings server's `ResetPosition` event, the CAN `ResetPosition` signal -- or `reset_car`,
OpenDS's RESET_CAR key R, on a task without reset points); each reset is recorded with its
step's action and as a `reset` event (`/events`). The drive ends when the task ends (the env
terminates) or its time limit truncates it, after `duration_s`, on Escape (shutdown),
closing the window or Ctrl-C; the recording is flushed every simulated second and finished
on the way out.
"""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from .controls_builder import ControlsBuilder
from .inputs.base import InputFrame
from .pacing import PacingClock, PacingStats
from .session_config import DriveConfig
from .snapshot import VehicleSnapshot, snapshot_of
from .sound import SoundLogEntry, SoundPlayer
from .sources import Sources, build_sources
from .view_state import ViewState

log = logging.getLogger(__name__)
CLOSE_KEYS = frozenset({"KEY_RETURN", "KEY_SPACE"})
HOLD_POLL_S = 1.0 / 60.0  # how often a held drive looks at its devices
PAUSE_COMMANDS = {"toggle_pause": None, "start_pause": True, "stop_pause": False}


@dataclass
class SessionResult:
    env_id: str
    metrics: dict[str, float]
    end_reason: str
    steps: int
    sim_time_s: float
    wall_s: float
    frames: int
    frame_times_s: list[float]
    pacing: PacingStats
    recordings: list[str]
    sounds: list[SoundLogEntry]
    reactions: list[dict[str, Any]]
    holds: list[tuple[float, str]] = field(default_factory=list)
    input_problems: int = 0
    warnings: list[str] = field(default_factory=list)

    @property
    def mean_fps(self) -> float:
        return self.frames / self.wall_s if self.wall_s > 0 else 0.0


class DriveSession:
    """One human drive (see the module docstring). Use as a context manager or call `close`."""

    def __init__(self, config: DriveConfig, *, joystick_backend: Any = None, viewer_factory: Any = None) -> None:
        import gymnasium as gym

        from ..envs.registration import resolve_env_id

        self.config = config
        env_id, kwargs = resolve_env_id(config.target)
        # a person's drive goes on: leaving the road or a collision never ends it (OpenDS);
        # the car is put back by `reset_position` (key, CAN, settings server)
        kwargs.update(on_road_exit="continue", terminate_on_collision=False)
        kwargs.update(config.env_kwargs)
        kwargs.update(physics=config.physics, physics_hz=config.physics_hz, policy_hz=config.physics_hz, action="controls")
        if config.duration_s is not None:
            kwargs["max_episode_s"] = config.duration_s
        self.env_id = env_id
        env: Any = gym.make(env_id, **kwargs)
        base = env.unwrapped
        self.base = base
        self.world = base.world
        settings = self.world.task.settings
        self.driver = config.driver or settings.general.driver_name
        self.recorder_wrapper: Any = None
        if config.record_path:
            from ..record import RecordDrive

            meta = {"session": "human", "driver": str(self.driver), "inputs": ",".join(str(s) for s in config.inputs)}
            env = RecordDrive(
                env,
                config.record_path,
                meta=meta,
                flush_interval_s=1.0,
                video_rate_hz=config.record_video_hz,
                video_format=config.video_format,
            )
            self.recorder_wrapper = env
        self.env = env
        self.sources: Sources = build_sources(config, self.world.task, joystick_backend)
        self.builder = ControlsBuilder(self.world)
        self.sound = SoundPlayer(self.world.task, enabled=config.audio and config.window)
        self.external_vis: Any = None
        ev = settings.external_visualization
        if ev is not None and ev.enable_connection:
            from .external_vis import ExternalVisualization

            self.external_vis = ExternalVisualization.from_settings(ev)
        self.view = ViewState.from_settings(settings)
        self.viewer: Any = None
        if config.window:
            from .viewer import make_viewer

            factory = viewer_factory or make_viewer
            try:
                self.viewer = factory(self.world, settings, config.width, config.height, title=f"opends-gym drive: {env_id}")
            except Exception as e:  # no display: free the devices and sockets, then explain
                self._closed = False
                self.close()
                raise RuntimeError(f"cannot open the drive window ({e}); on a machine without a display use --no-window") from e
        elif self.sources.needs_pygame_events:
            from .viewer import init_headless_pygame

            init_headless_pygame()
        if self.sources.keyboard is not None and not config.window:
            log.warning("keyboard input without a window: no keys can be read (only scripted key events drive)")
        self.hold_instructions = config.hold_on_instructions if config.hold_on_instructions is not None else config.window
        self.max_steering_deg = math.degrees(settings.can_interface.max_steering_angle_rad)
        self.snapshot = VehicleSnapshot()
        self.paused = bool(settings.general.pause_after_startup) and config.window
        self.instruction: str | None = None
        self.stop_reason = ""
        self.frames = 0
        self.frame_times: list[float] = []
        self.holds: list[tuple[float, str]] = []  # (simulation time, reason) each time the drive was held
        self._event_cursor = 0
        self._warned: set[str] = set()
        self._stop = threading.Event()
        self._closed = False

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> DriveSession:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def reset_position(self) -> None:
        """Put the car back at rest on its last lane position with the next step
        (`OpenDSEnv.reset_position`; recorded with that step's action and as a `reset` event)."""
        log.info("car reset to its last lane position at %.3f s", self.world.t_s)
        self.base.reset_position()

    def request_stop(self, reason: str = "stopped") -> None:
        """Ask the loop to end after the current step (thread-safe; signal handlers use it)."""
        self.stop_reason = self.stop_reason or reason
        self._stop.set()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for closer in (self.sources.combiner.close, self.sound.close, self.env.close):
            try:
                closer()
            except Exception:  # closing one part must not keep the recording from finishing
                log.exception("closing the session")
        if self.external_vis is not None:
            self.external_vis.close()
        if self.viewer is not None:
            self.viewer.close()

    # ------------------------------------------------------------------ loop
    def run(self) -> SessionResult:
        cfg = self.config
        self.env.reset(seed=cfg.seed)
        self._event_cursor = 0
        self._after_step()
        if self.viewer is not None:  # the first frame loads fonts and builds caches: not on the clock
            self.viewer.draw(self._overlay(self._hold_reason()))
        batch = 1 if self.viewer is None else 4  # --fast with a window: a frame every 4 steps
        clock = PacingClock(self.world.dt_s, fast=cfg.fast, max_catch_up_steps=cfg.max_catch_up_steps, fast_batch=batch)
        started = time.perf_counter()
        previous = _install_sigterm(self)
        done = False
        last_hold = ""
        try:
            while not done and not self._stop.is_set():
                t0 = time.perf_counter()
                self._pump_events()
                hold = self._hold_reason()
                if hold and hold != last_hold:
                    self.holds.append((self.world.t_s, hold))
                    log.info("drive held at %.3f s: %s", self.world.t_s, hold)
                last_hold = hold
                if hold:
                    clock.hold()
                    self._poll_while_held()
                    time.sleep(HOLD_POLL_S)
                else:
                    for _ in range(clock.steps_due()):
                        done = self._step()
                        clock.advance(1)
                        if done or self._stop.is_set() or self._hold_reason():
                            break
                if self.viewer is not None:
                    self.viewer.draw(self._overlay(hold))
                    self.frames += 1
                    self.frame_times.append(time.perf_counter() - t0)
                clock.wait()
        except KeyboardInterrupt:
            self.stop_reason = self.stop_reason or "interrupted (Ctrl-C)"
        finally:
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
        wall = time.perf_counter() - started
        if self.viewer is not None and cfg.screenshot_path:
            try:
                self.viewer.save_png(cfg.screenshot_path)
            except Exception as e:  # a screenshot must not cost the session its results
                self._warn_once("screenshot", f"screenshot not saved: {e}")
        return self._result(wall, clock.stats)

    def _hold_reason(self) -> str:
        if self.paused:
            return "PAUSED - press P to continue"
        if self.instruction is not None:
            return f"Instructions: {self.instruction} - press Return to continue"
        blocking = self.sources.combiner.blocking()
        return blocking.message if blocking is not None else ""

    def _pump_events(self) -> None:
        if self.viewer is not None:
            events = self.viewer.events()
        elif self.sources.needs_pygame_events:
            import pygame

            events = pygame.event.get()
        else:
            return
        import pygame

        for ev in events:
            if ev.type == pygame.QUIT:
                self.request_stop("window closed")
            elif ev.type == getattr(pygame, "WINDOWFOCUSLOST", -1) and self.sources.keyboard is not None:
                self.sources.keyboard.release_all()
            if self.sources.keyboard is not None:
                self.sources.keyboard.handle_event(ev)
            if self.sources.joystick is not None:
                self.sources.joystick.handle_event(ev)

    def _poll_while_held(self) -> None:
        """Sources are read while held (for resume and close keys); their edges do not drive."""
        frame = self.sources.combiner.poll(self.world.t_s)
        self._runner_commands(frame)
        if self.instruction is not None and (CLOSE_KEYS & set(frame.keys) or frame.buttons or "close_instruction_screen" in frame.commands):
            log.info("instruction screen %s closed at %.3f s", self.instruction, self.world.t_s)
            self.instruction = None

    def _step(self) -> bool:
        w = self.world
        frame = self.sources.combiner.poll(w.t_s)
        self._runner_commands(frame)
        self._apply_traffic(frame)
        controls = self.builder.build(frame)
        action = self.base.act_type.encode(controls)
        _, _, terminated, truncated, info = self.env.step(action)
        self._after_step()
        if terminated or truncated:
            self.final_info = info
            self.stop_reason = self.stop_reason or ("task ended" if terminated else "time limit")
            return True
        if self.config.duration_s is not None and w.t_s >= self.config.duration_s - 1e-9:
            self.stop_reason = self.stop_reason or "duration reached"
            return True
        return False

    def _after_step(self) -> None:
        w = self.world
        self.snapshot = snapshot_of(w, self.snapshot, self.max_steering_deg)
        src = self.sources
        if src.server is not None:
            src.server.publish(self.snapshot)
        for s in src.feedback:
            try:
                s.feedback(self.snapshot)
            except Exception as e:  # feedback is best effort
                self._warn_once(f"feedback:{s.name}", f"{s.name} feedback failed: {e}")
        if self.external_vis is not None:
            self.external_vis.update(self.snapshot)
        for ev in w.events.since(self._event_cursor):
            if ev.kind == "sound":
                self.sound.handle(ev.t_s, ev.source, str(ev.params.get("op", "play")))
            elif ev.kind == "instructions" and ev.params.get("op") == "open" and self.hold_instructions:
                self.instruction = ev.source
        self._event_cursor = len(w.events)

    def _runner_commands(self, frame: InputFrame) -> None:
        for text, duration in frame.messages:
            self.view.show_message(text, duration, time.monotonic())
        for cmd in frame.commands:
            if cmd in PAUSE_COMMANDS:
                want = PAUSE_COMMANDS[cmd]
                self.paused = (not self.paused) if want is None else want
            elif cmd == "shutdown":
                self.request_stop("shutdown key")
            elif cmd == "close_instruction_screen":
                self.instruction = None
            elif cmd == "reset_position" or (cmd == "reset_car" and not self.builder.reset_ids):
                self.reset_position()
            elif cmd.startswith("reset_car"):
                pass  # resolved into DriverControls.reset_to by the builder
            elif not self.view.command(cmd):
                self._warn_once(cmd, f"function '{cmd}' is not available in this simulator")

    def _apply_traffic(self, frame: InputFrame) -> None:
        if not frame.traffic_controls:
            return
        traffic = self.world.traffic
        setter = getattr(traffic, "set_external_control", None) if traffic is not None else None
        for tc in frame.traffic_controls:
            if setter is None:
                self._warn_once("traffic-control", "this task has no traffic under external control; SetVehicleControl ignored")
                continue
            try:
                setter(tc.vehicle_id, tc.steering, tc.accelerator, tc.brake)
            except Exception as e:  # unknown id or a car that cannot be controlled
                self._warn_once(f"traffic:{tc.vehicle_id}", f"SetVehicleControl {tc.vehicle_id}: {e}")

    def _warn_once(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            log.warning(message)

    def _overlay(self, hold: str) -> Any:
        from .view_state import Overlay

        statuses = [s for s in self.sources.combiner.statuses() if s.message and not s.connected]
        return Overlay(
            hold=hold,
            instruction=self.instruction,
            paused=self.paused,
            messages=self.view.messages(time.monotonic()),
            status=[s.message for s in statuses],
            view=self.view,
            snapshot=self.snapshot,
        )

    def _result(self, wall_s: float, stats: PacingStats) -> SessionResult:
        info = getattr(self, "final_info", None)
        metrics = dict(info["episode_metrics"]) if info and "episode_metrics" in info else self.base.episode_metrics()
        recordings: list[str] = []
        if self.recorder_wrapper is not None:
            rec = self.recorder_wrapper.recorder
            paths = list(self.recorder_wrapper.paths) + (list(rec.paths) if rec is not None else [])
            recordings = [str(p) for p in dict.fromkeys(paths)]
        reactions = [
            {"timer": r.timer_id, "group": r.group, "result": r.result, "reaction_time_s": r.reaction_time_s, "t_s": r.t_s}
            for r in self.world.triggers.reactions
        ]
        problems = sum(int(getattr(s, "problems", 0)) for s in self.sources.combiner.sources)
        return SessionResult(
            env_id=self.env_id,
            metrics=metrics,
            end_reason=self.stop_reason or "stopped",
            steps=self.world.step_count,
            sim_time_s=self.world.t_s,
            wall_s=wall_s,
            frames=self.frames,
            frame_times_s=self.frame_times,
            pacing=stats,
            recordings=recordings,
            sounds=list(self.sound.log),
            reactions=reactions,
            holds=list(self.holds),
            input_problems=problems,
            warnings=sorted(self._warned),
        )


def _install_sigterm(session: DriveSession) -> Any:
    """SIGTERM ends the drive cleanly (recording finished), like Ctrl-C. Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return None
    try:
        return signal.signal(signal.SIGTERM, lambda *_: session.request_stop("terminated (SIGTERM)"))
    except (ValueError, OSError):
        return None
