"""`OpenDSEnv`: the one `step()` every OpenDS environment shares.

Why: task envs differ in reward, stimuli, termination and summary metrics, not in how a
policy step runs. This base owns `reset`/`step`/`render` (Gymnasium API to the letter) and
calls small hooks that task envs override (`_make_task`, `_setup`, `_reset_task`,
`_on_physics_step`, `_stimulus`, `_reward`, `_task_terminated`, `_task_info`,
`_episode_metrics`).

Info keys (finite numbers or inf, never NaN, so they batch in vector envs and compare
equal across seeded runs):
  sim_time_s, speed_kmh, lateral_offset_m (from the lane centre, + left), lane_index
  (-1 off the lanes), fuel_used_l, collisions (count so far), reaction_result (1 correct,
  -1 failure, -2 missed, 0 none this step), reaction_time_s (of that reaction; 0 when
  none; misses are 10 s as OpenDS's 10000 ms), mean_deviation_m (running; the final
  OpenDS/ISO value is in episode_metrics), sdlp_m (running over lane-keeping samples, 0
  until there are two), headway_s (front-to-front to the lead, inf without one), ttc_s
  (inf unless closing in), lanes_known (the task defines the lanes lateral offset and
  lane index are measured in, here: OpenDS X-band lanes, OpenDRIVE lanes or Gen B road
  segments; otherwise, and on the curve that joins a start off every road to the task's
  roads, they are measured from the ego's route, see `sim.guide.RoadGuide`).
  `events`: tuple of event dicts emitted this step (the documented non-numeric key).
  `episode_metrics`: dict of the task's summary, present only on the last step; the base
  adds lanes_known (0/1), mean_abs_lateral_offset_m (mean |lateral_offset_m| over physics
  steps) and off_road_s (simulated seconds beyond the road's edges), and the measures that
  follow the standards (docs/metrics.md): sdlp_j2944_m over fixed 30 s segments with
  sdlp_j2944_valid_fraction, sdlp_j2944_excluded_fraction, sdlp_j2944_segments,
  sdlp_j2944_segments_valid; steering_reversal_rate_{0_5,2,10}deg_per_min on lane keeping;
  car following with both speeds: lead_share, following_share, thw_mean_s, thw_min_s,
  thw_below_{1,2}s_share (THW and mean_headway_s over the car-following samples only,
  `metrics.headway.FOLLOWING`), ttc_below_{1_5,3}s_share.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils import EzPickle

from ..metrics.headway import car_following_summary, following_mask, time_headway, time_to_collision
from ..metrics.lateral import SDLP_MIN_VALID_FRACTION, SDLP_SEGMENT_S, lane_keeping_mask, sdlp, sdlp_segments
from ..metrics.steering import gap_key, reversal_rate, reversal_rates
from ..sim.controls import STEERING_WHEEL_MAX_DEG, DriverControls
from ..sim.guide import RoadGuide
from ..sim.perception import lead_vehicle
from ..sim.world import World, WorldConfig
from ..task import DrivingTask
from .actions import make_action_type
from .collision import COLLISION_SOURCE, PASSED_LEAD_SOURCE, collision_mode, collision_reset_pose
from .config import EnvConfig, build_config
from .observations import make_observation_type
from .road_exit import RESET_SOURCE, LanePose, check_mode, held
from .start_pose import parse_start_pose
from .trace import COL, Trace

LANE_KEEPING_OFFSET_M = 1.0  # |offset from lane centre| below which a sample counts for SDLP
_X, _Z, _OFFSET, _LANE, _T = COL["x_m"], COL["z_m"], COL["lane_offset_m"], COL["lane_index"], COL["t_s"]
SETTLED_LANE_S = 1.0  # a reset puts the car back in the last lane it drove in this long (opends_gym.envs.road_exit)


class OpenDSEnv(gym.Env[np.ndarray, Any], EzPickle):
    """Base class; see the module docstring for the shared info keys."""

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}
    config_class: ClassVar[type[EnvConfig]] = EnvConfig
    stimulus_names: ClassVar[tuple[str, ...]] = ()

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        EzPickle.__init__(self, render_mode=render_mode, **kwargs)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, not {render_mode!r}")
        self.config = build_config(self.config_class, kwargs)
        self.on_road_exit = check_mode(self.config.on_road_exit)
        self.on_collision = collision_mode(self.config.on_collision, self.config.terminate_on_collision)
        # one rendered frame per policy step: RecordVideo and the window play in real time
        self.metadata = {**type(self).metadata, "render_fps": self.config.policy_hz}
        self.render_mode = render_mode
        self.task: DrivingTask = self._make_task()
        self.world = World(self.task, WorldConfig(physics=self.config.physics, dt_s=1.0 / self.config.physics_hz))
        self.guide = RoadGuide(self.world)
        self._lane_position = self.guide.lane_position
        self._setup()
        self.obs_type = make_observation_type(
            self.config.observation, self.world, self.guide, self.config, self._stimulus, self.stimulus_names
        )
        self.act_type = make_action_type(self.config.action, self.world, self.guide, self.config)
        self.observation_space = self.obs_type.space()
        self.action_space = self.act_type.space()
        self.trace = Trace()
        self._run = RunningLateral()
        self.controls = DriverControls()
        self._renderer: Any = None
        self._window: Any = None
        self._episode_over = False
        self._engine_key: bool | None = None
        self._reset_rows: list[int] = []
        self._reset_request = self._reset_due = False
        self._hold_until_s = -math.inf
        self._collision_due: bool = False  # (on_collision="recover": a reset at the next physics step)
        self._collisions_handled: int = 0
        self._clear_road_exits()

    # ------------------------------------------------------------------ hooks
    def _make_task(self) -> DrivingTask:
        raise NotImplementedError

    def _setup(self) -> None:
        """After the World is built (register action handlers, precompute task data)."""

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        """After the World is reset, before the first observation."""

    def _transform_controls(self, controls: DriverControls) -> DriverControls:
        """What actually drives the car (ConTRe drives it itself and keeps the agent's)."""
        return controls

    def _on_physics_step(self) -> None:
        """After every physics step (accumulate task measures); `self.controls` is current."""

    def _stimulus(self) -> list[float]:
        """Task stimulus features appended to vector observations (`stimulus_names`)."""
        return []

    def _reward(self, info: dict[str, Any]) -> float:
        """Default: progress along the road in metres, minus lane offset and collisions."""
        return float(info["progress_m"]) - 0.1 * abs(float(info["lateral_offset_m"])) - 10.0 * float(info["new_collisions"])

    def _task_terminated(self) -> bool:
        """The task is over (end of track, test voided); leaving the road is `_off_road`."""
        return False

    def _off_road(self) -> bool:
        """The car has left the road (handled by `on_road_exit`)."""
        return self._off_road_at(self.trace.last("lateral_m"))

    def _off_road_at(self, lateral_m: float) -> bool:
        """Whether a lateral position (the guide's, + left) is off the road. Default: more than
        `off_road_margin_m` beyond the road's edges (`RoadGuide.road_edges_m`; never where no
        road is known). Envs with their own road test override this."""
        left, right = self.guide.road_edges_m
        margin = self.config.off_road_margin_m
        return lateral_m > left + margin or lateral_m < right - margin

    def _after_reset_position(self) -> None:
        """After the car was put back on its lane (task measures that integrate along the road
        restart from the new position)."""

    def _stimuli_presented(self) -> int:
        """How many stimuli the driver was shown this episode (exposure). Default: the
        World's `stimulus` events plus the reaction timers scored."""
        n = sum(1 for e in self.world.events.since(0) if e.kind == "stimulus")
        return n + len(getattr(self.world.triggers, "reactions", ()))

    def _task_info(self, info: dict[str, Any]) -> None:
        """Add or override numeric info keys."""

    def _episode_metrics(self) -> dict[str, float]:
        """The task's summary; the base adds the generic driving measures."""
        return {}

    def _instructed_lane_keeping(self) -> np.ndarray | None:
        """Per trace row: True outside the task's instructed lane changes (None: the task
        instructs none). SDLP (SAE J2944) excludes those samples only, and the reversal
        rates are counted on these lane-keeping stretches."""
        return None

    def _sdlp_lateral(self) -> np.ndarray:
        """Per trace row: the lateral position SDLP is taken of (m; a road-fixed lateral
        position by default, relative to the instructed lane where the task has one)."""
        return self.trace.col("lateral_m")

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Back to the task's start; `options={"start_pose": {x, y, z, yaw_rad[, speed_mps, engine_on]}}`
        starts the car in that state instead (a recorded drive's first row, `envs.start_pose`)."""
        super().reset(seed=seed)
        start = parse_start_pose(options)
        self.world.reset(seed=int(self.np_random.integers(0, 2**31 - 1)))
        if start is not None:  # a recorded drive's first state (opends_gym.envs.start_pose)
            ego = self.world.ego
            engine = ego.powertrain.state.engine_on if start.engine_on is None else start.engine_on
            ego.reset_to(start.x, start.y, start.z, start.yaw_rad, start.speed_mps, engine_on=engine)
        self.guide.reset()
        self.act_type.reset()
        self.trace.clear()
        self._run = RunningLateral()
        self._reset_rows = []  # trace rows right after a reset (no distance from the row before)
        self._event_cursor = 0
        self._reaction_cursor = 0
        self._collisions_seen = 0
        self._last_s = self.guide.locate(self.world.ego.state.x, self.world.ego.state.z).s_m
        self._episode_over = False
        self._engine_key = None
        self._clear_road_exits()
        self._reset_task(options)
        self._record_row()
        info = self._info(progress_m=0.0, new_collisions=0, events=())
        return self.obs_type.observe(), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._episode_over:
            raise RuntimeError("step() called after the episode ended; call reset() first")
        controls = self._transform_controls(self.act_type.to_controls(action))
        if self._engine_key is not None:  # the ignition key turned since the last step
            controls = DriverControls(**controls.__dict__)
            controls.engine_on, self._engine_key = self._engine_key, None
        applied = controls.clipped()  # what the world gets: clipped once for the action repeat
        world = self.world
        self._exits_this_step = 0
        for k in range(self.config.action_repeat):
            if self._collision_due:  # on_collision="recover"
                self._collision_due = self._reset_request = self._reset_due = False
                self._reset_to_lane(collision=True)
            elif self._reset_request or self._reset_due:  # reset_position() or on_road_exit="recover"
                self._reset_request = self._reset_due = False
                self._reset_to_lane()
            self.controls = controls
            self._inputs_held = world.t_s < self._hold_until_s - 1e-9
            world.step_clipped(held(applied) if self._inputs_held else applied)
            self._record_row()
            self._on_physics_step()
            self._road_exit()
            if self.on_collision == "recover" and world.collisions > self._collisions_handled:
                self._collisions_handled = world.collisions
                self._collision_due = True  # at the start of the next physics step, as a road exit
            if k == 0:
                controls = _without_edges(controls)
                applied = _without_edges(applied)
            if self._stop_early():
                break
        s = world.ego.state
        s_now = self.guide.locate(s.x, s.z).s_m
        progress = s_now - self._last_s
        self._last_s = s_now
        new_collisions = world.collisions - self._collisions_seen
        self._collisions_seen = world.collisions
        events = world.events.since(self._event_cursor)
        self._event_cursor = len(world.events)
        info = self._info(progress_m=progress, new_collisions=new_collisions, events=tuple(e.to_dict() for e in events))
        reward = float(self._reward(info))
        terminated = bool(self._terminated(new_collisions))
        truncated = bool(not terminated and world.t_s >= self.config.max_episode_s - 1e-9)
        if terminated or truncated:
            self._episode_over = True
            info["episode_metrics"] = self.episode_metrics()
        if self.render_mode == "human":
            self.render()
        return self.obs_type.observe(), reward, terminated, truncated, info

    def turn_engine_key(self, on: bool = True) -> None:
        """The driver turns the ignition key: the engine is switched on (off) with the next
        step, whatever the action type carries (OpenDS: the TOGGLE_ENGINE key of
        `SimulatorActionListener` calls `Car.setEngineOn`; a task with `<engineOn>` false
        starts with the engine off and the accelerator does nothing until then)."""
        self._engine_key = bool(on)

    @property
    def pending_engine_key(self) -> bool | None:
        """The ignition key turned for the next step (recordings keep it beside the action)."""
        return self._engine_key

    def reset_position(self) -> None:
        """Put the car back at rest in the centre of the lane it was last in, where it was
        last in it, at the start of the next step, and hold it `reset_hold_s` (the experimenter's reset,
        OpenDS's `Car.setToResetPosition`; the same reset `on_road_exit="recover"` does).
        Counted in info `resets` and marked by a World `reset` event (`last_lane_position`)."""
        self._reset_request = True

    @property
    def pending_reset_position(self) -> bool:
        """`reset_position()` was asked for the next step (recordings keep it beside the action)."""
        return self._reset_request

    # ------------------------------------------------------------------ leaving the road
    def _clear_road_exits(self) -> None:
        self._reset_request = self._reset_due = False
        self._lane_row: tuple[float, ...] | None = None
        self._lane_now, self._lane_since_s, self._settled_lane = -1, 0.0, -1
        self._lane_y = 0.0
        self._off_now = False
        self._hold_until_s = -math.inf
        self._inputs_held = False  # this physics step's inputs were held (after a reset)
        self._was_off_road = False
        self.road_exits = 0  # times the car left the road (each exit once)
        self.resets = 0  # resets to the last lane position (automatic and requested) and after collisions
        self.collision_resets = 0  # resets after collisions (on_collision="recover")
        self._collision_due = False
        self._collisions_handled = 0
        self.reset_time_s = 0.0  # simulated seconds held still after resets
        self._exits_this_step = 0
        self._skip_distance = False

    def _road_exit(self) -> None:
        """After each physics step: remember the last lane position; count and handle exits.
        (Every physics step: the trace row and the car's height are kept, the pose is worked
        out only when a reset needs it.)"""
        row = self.trace.last_row()
        off = self._off_road()
        self._off_now = off
        if off:
            if not self._was_off_road:
                self.road_exits += 1
                self._exits_this_step += 1
            if self.on_road_exit == "recover":
                self._reset_due = True  # at the start of the next physics step (info and observation show where it left the road)
        elif row[_LANE] >= 0:
            self._lane_row, self._lane_y = row, self.world.ego.state.y
            lane = int(row[_LANE])
            if lane != self._lane_now:
                self._lane_now, self._lane_since_s = lane, row[_T]
            elif row[_T] - self._lane_since_s >= SETTLED_LANE_S:
                self._settled_lane = lane
        self._was_off_road = off

    def _lane_pose(self) -> LanePose | None:
        """Where the car was last on a lane, moved across into the centre of the lane it last
        drove in for `SETTLED_LANE_S` (a lane it only crossed on its way off the road is not
        it), facing along the road."""
        row = self._lane_row
        if row is None:
            return None
        x, z = row[_X], row[_Z]
        p = self.guide.locate(x, z)
        lane = self._settled_lane if self._settled_lane >= 0 else int(row[_LANE])
        offset = p.lateral_m - self.guide.lane_laterals_m[lane]
        return LanePose(x, self._lane_y, z, offset, self.guide.heading_at(p.s_m))

    def _reset_to_lane(self, collision: bool = False, behind: tuple[float, float, int] | None = None) -> None:
        """Put the car back at rest and hold it: at the last lane position, after a
        collision behind what it hit, or behind the point (x, z) in lane `behind`
        (`opends_gym.envs.collision`)."""
        w = self.world
        if behind is not None:
            pose = collision_reset_pose(w, self.guide, behind[2], (behind[0], behind[1]))
        elif collision:
            lane = int(self.trace.last("lane_index"))
            pose = collision_reset_pose(w, self.guide, lane if lane >= 0 else self._settled_lane)
            self.collision_resets += 1
        else:
            lane_pose = self._lane_pose()
            pose = lane_pose.lane_centre_pose() if lane_pose is not None else w.start_pose
        w.ego.teleport(pose)
        self.resets += 1
        hold = self.config.reset_hold_s
        self._hold_until_s = w.t_s + hold
        self.reset_time_s += hold
        self._was_off_road = self._off_now = False
        self._skip_distance = True  # the jump is no distance driven
        x, _, z = pose.position_m
        source = PASSED_LEAD_SOURCE if behind is not None else COLLISION_SOURCE if collision else RESET_SOURCE
        w.events.emit(w.t_s, "reset", source, x_m=x, z_m=z, yaw_rad=pose.yaw_rad, hold_s=hold, resets=self.resets)
        self.guide.reset()
        self._last_s = self.guide.locate(x, z).s_m
        self._after_reset_position()

    def _stop_early(self) -> bool:
        return self._terminated(self.world.collisions - self._collisions_seen)

    def _terminated(self, new_collisions: int) -> bool:
        trig = self.world.triggers
        if getattr(trig, "shutdown_requested", False):
            return True
        if getattr(trig, "paused", False) and math.isinf(getattr(trig, "pause_until_s", 0.0)):
            return True  # paused "until resumed": nobody resumes an RL episode
        if self.on_collision == "terminate" and new_collisions > 0:
            return True
        if self._off_now and self.on_road_exit == "terminate":
            return True
        return self._task_terminated()

    # ------------------------------------------------------------------ info
    def _record_row(self) -> None:
        w = self.world
        s = w.ego.state
        x, z = s.x, s.z
        _, lateral, lane, offset = self._lane_position(x, z)
        lead = lead_vehicle(w) if w.traffic is not None else None
        if lead is not None:
            headway = time_headway(lead.gap_m, lead.length_m, s.u)
            ttc = time_to_collision(lead.gap_m, s.u, lead.speed_mps)
            gap, lead_speed = lead.gap_m, lead.speed_mps
        else:
            headway = ttc = gap = math.inf
            lead_speed = math.nan
        inp = w.ego.inputs
        tr = self.trace
        prev = tr.last_row()
        run = self._run
        if self._skip_distance:
            self._skip_distance = False
            self._reset_rows.append(tr.n)
            prev = ()
        if prev:
            ds = math.hypot(x - prev[_X], z - prev[_Z])
            run.dist += ds
            run.area += 0.5 * (abs(prev[_OFFSET]) + abs(offset)) * ds  # (RunningLateral.add_distance, inlined)
        run.add_offset(offset)
        gas, brake = self.driver_pedals()
        tr.append((w.t_s, x, z, s.yaw, s.u, lateral, offset, float(lane), inp.steering, gas, brake, headway, ttc, gap,
                   lead_speed))  # fmt: skip

    def driver_pedals(self) -> tuple[float, float]:
        """(accelerator, brake) the driver applies this physics step. While the car is held
        after a reset the car gets full brake, but the driver's own pedals are what the
        reaction measures score (a held car is no brake response)."""
        w = self.world
        if self._inputs_held:
            c = self.controls
            return min(max(float(c.accelerator), 0.0), 1.0), min(max(float(c.brake), 0.0), 1.0)
        inp = w.ego.inputs
        return inp.accelerator, inp.brake

    def _new_reaction(self) -> tuple[float, float]:
        reactions: Any = getattr(self.world.triggers, "reactions", ())
        if len(reactions) <= self._reaction_cursor:
            return 0.0, 0.0
        last = reactions[-1]
        self._reaction_cursor = len(reactions)
        return float(last.result), float(last.reaction_time_s)

    def _info(self, progress_m: float, new_collisions: int, events: tuple[dict[str, Any], ...]) -> dict[str, Any]:
        w = self.world
        tr = self.trace
        result, rt = self._new_reaction()
        info: dict[str, Any] = {
            "sim_time_s": w.t_s,
            "speed_kmh": w.ego.state.u * 3.6,
            "lateral_offset_m": tr.last("lane_offset_m"),
            "lane_index": int(tr.last("lane_index")),
            "fuel_used_l": w.ego.powertrain.state.fuel_used_l,
            "collisions": w.collisions,
            "reaction_result": result,
            "reaction_time_s": rt,
            "mean_deviation_m": self._run.mean_deviation_m,
            "sdlp_m": self._run.sdlp_m,
            "headway_s": tr.last("headway_s"),
            "ttc_s": tr.last("ttc_s"),
            "lanes_known": self.guide.lanes_known_at(self._last_s),
            "resets": self.resets,
            "reset_time_s": self.reset_time_s,
            "progress_m": progress_m,
            "new_collisions": new_collisions,
            "events": events,
        }
        self._task_info(info)
        return info

    def episode_metrics(self) -> dict[str, float]:
        """Summary of the episode so far (the `episode_metrics` info of the last step)."""
        tr = self.trace
        offsets = tr.col("lane_offset_m")
        fs = self.config.physics_hz
        steer_deg = tr.col("steering") * STEERING_WHEEL_MAX_DEG
        following = following_mask(tr.col("t_s"), tr.col("gap_m"), tr.col("speed_mps"), tr.col("lead_speed_mps"))
        finite_h = tr.col("headway_s")[following]  # front to front, while car following (metrics.headway.FOLLOWING)
        ttc = tr.col("ttc_s")
        finite_t = ttc[np.isfinite(ttc)]
        reactions: Any = getattr(self.world.triggers, "reactions", ())
        correct = [r for r in reactions if r.result == 1]
        out: dict[str, float] = {
            "duration_s": self.world.t_s,
            "distance_m": self._distance_m(),
            "mean_speed_kmh": float(np.mean(tr.col("speed_mps")) * 3.6) if tr.n else math.nan,
            "fuel_used_l": self.world.ego.powertrain.state.fuel_used_l,
            "collisions": float(self.world.collisions),
            "sdlp_m": sdlp(offsets, lane_keeping_mask(tr.col("t_s"), tr.col("lane_index"))),
            "steering_reversal_rate_per_min": reversal_rate(steer_deg, fs, gap_deg=2.0, cutoff_hz=0.6) if tr.n > 3 else math.nan,
            "mean_headway_s": float(np.mean(finite_h)) if len(finite_h) else math.nan,
            "min_ttc_s": float(np.min(finite_t)) if len(finite_t) else math.inf,
            "reactions": float(len(reactions)),
            "reactions_correct": float(len(correct)),
            "reactions_failed": float(sum(1 for r in reactions if r.result == -1)),
            "reactions_missed": float(sum(1 for r in reactions if r.result == -2)),
            "mean_reaction_time_s": float(np.mean([r.reaction_time_s for r in correct])) if correct else math.nan,
            "lanes_known": float(self.guide.lanes_known),
            "mean_abs_lateral_offset_m": float(np.mean(np.abs(offsets))) if tr.n else math.nan,
            "off_road_s": self._off_road_s(),
            "stimuli_presented": float(self._stimuli_presented()),
            "road_exits": float(self._road_exits_in_trace()),
            "resets": float(self.resets),
            "collision_resets": float(self.collision_resets),
            "reset_time_s": self.reset_time_s,
        }
        out.update(self._standard_metrics(steer_deg, fs))
        out.update(self._episode_metrics())
        return out

    def _road_exits_in_trace(self) -> int:
        """Times the car left the road (from the trace, so a batch's template scores it too)."""
        lat = self.trace.col("lateral_m")
        if len(lat) == 0:
            return 0
        off = self._off_road_mask(lat)
        return int(np.count_nonzero(off[1:] & ~off[:-1]) + off[0])

    def _off_road_mask(self, lateral_m: np.ndarray) -> np.ndarray:
        """`_off_road_at` of each lateral position (envs with a plain road-width test do it as
        one array operation: episode scoring runs it over the whole trace)."""
        return np.fromiter((self._off_road_at(float(v)) for v in lateral_m), dtype=bool, count=len(lateral_m))

    def _distance_m(self) -> float:
        """Metres driven (the jumps of resets to the last lane position left out)."""
        tr = self.trace
        if tr.n < 2:
            return 0.0
        ds = np.hypot(np.diff(tr.col("x_m")), np.diff(tr.col("z_m")))
        if self._reset_rows:
            ds[np.asarray(self._reset_rows) - 1] = 0.0
        return float(np.sum(ds))

    def _standard_metrics(self, steer_deg: np.ndarray, fs: float) -> dict[str, float]:
        """SDLP per SAE J2944, reversal rates at three gaps on lane keeping, car following
        with both speeds (`docs/metrics.md` lists the keys and their sources)."""
        tr = self.trace
        t = tr.col("t_s")
        instructed = self._instructed_lane_keeping()
        exclude = None if instructed is None else ~instructed
        res = sdlp_segments(t, self._sdlp_lateral(), exclude, None, SDLP_SEGMENT_S, SDLP_MIN_VALID_FRACTION)
        out = {
            "sdlp_j2944_m": res.sdlp_m,
            "sdlp_j2944_valid_fraction": res.valid_fraction,
            "sdlp_j2944_excluded_fraction": res.excluded_fraction,
            "sdlp_j2944_segments": float(len(res.segments)),
            "sdlp_j2944_segments_valid": float(res.segments_valid),
        }
        keep = instructed if instructed is not None else lane_keeping_mask(t, tr.col("lane_index"))
        for gap, rate in reversal_rates(steer_deg, fs, keep).items():
            out[f"steering_reversal_rate_{gap_key(gap)}_per_min"] = rate
        cf = car_following_summary(t, tr.col("gap_m"), tr.col("speed_mps"), tr.col("lead_speed_mps"))
        cf.pop("ttc_min_s")  # (min_ttc_s above)
        out.update({k.replace(".", "_"): v for k, v in cf.items()})
        return out

    def _off_road_s(self) -> float:
        """Simulated seconds the car's reference point spent beyond its road's edges
        (`RoadGuide.off_road`; 0 where no road is known)."""
        left, right = self.guide.road_edges_m
        lat = self.trace.col("lateral_m")[1:]  # (the reset row is no step)
        return float(np.count_nonzero((lat > left) | (lat < right))) / self.config.physics_hz

    # ------------------------------------------------------------------ render
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode")
            return None
        from ..render import make_renderer

        if self._renderer is None:
            self._renderer = make_renderer(self.config.extra.get("render_view", "topdown"), self.world, hud=self.render_mode == "human")
        frame = self._renderer.render(self.config.render_width, self.config.render_height)
        if self.render_mode == "rgb_array":
            return frame
        from ..render.window import FrameWindow

        if self._window is None:
            self._window = FrameWindow(self.config.render_width, self.config.render_height, title=type(self).__name__)
        self._window.show(frame, fps=self.metadata["render_fps"])
        return None

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Rebuild from the constructor arguments on *this* object. (EzPickle copies the
        attributes of a second instance, whose observation type would keep calling that
        instance's stimulus hooks and read its world.)"""
        self.__init__(*state["_ezpickle_args"], **state["_ezpickle_kwargs"])  # type: ignore[misc]

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None
        self.world.close()


class RunningLateral:
    """O(1)-per-sample running SDLP (Welford) and mean |lane offset| per metre driven."""

    def __init__(self) -> None:
        self.n = 0
        self.mean = 0.0
        self.m2 = 0.0
        self.area = 0.0
        self.dist = 0.0

    def add_offset(self, offset: float) -> None:
        if abs(offset) < LANE_KEEPING_OFFSET_M:
            self.n += 1
            d = offset - self.mean
            self.mean += d / self.n
            self.m2 += d * (offset - self.mean)

    def add_distance(self, ds: float, prev_abs: float, abs_now: float) -> None:
        self.dist += ds
        self.area += 0.5 * (prev_abs + abs_now) * ds

    @property
    def sdlp_m(self) -> float:
        return math.sqrt(self.m2 / self.n) if self.n >= 2 else 0.0

    @property
    def mean_deviation_m(self) -> float:
        return self.area / self.dist if self.dist > 0 else 0.0


def _without_edges(c: DriverControls) -> DriverControls:
    """The same inputs for the next physics substeps, minus one-shot key/button presses."""
    if not (
        c.keys
        or c.buttons
        or c.remote_triggers
        or c.reset_to
        or c.shift_up
        or c.shift_down
        or c.toggle_automatic
        or c.cruise_control is not None
    ):
        return c
    d = DriverControls(**c.__dict__)
    d.keys, d.buttons, d.remote_triggers, d.reset_to = (), (), (), None
    d.shift_up = d.shift_down = d.toggle_automatic = False
    d.cruise_control = None
    return d
