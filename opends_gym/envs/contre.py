"""`OpenDS/ConTRe-v0`: Continuous Tracking and Reaction (Mahr et al. 2012).

Why: ConTRe is OpenDS's adjustable-difficulty alternative to the LCT, but its classes are
closed source; we re-specify it from the public `task.xml` `steeringTask` block:

* the car drives itself along the task's camera-flight track at the flight speed (as in
  OpenDS, where the participant does not drive); the agent's steering moves the
  **steering bar** sideways at up to `steeringObject@speed` m/s, within
  [-maxRight, +maxLeft] m of the track (+ = left);
* the **target bar** moves towards a random goal in its own [-maxRight, +maxLeft] at
  `targetObject@speed` m/s (changed at run time by `setupContreTask targetObjectSpeed`),
  pauses `pauseAfterTargetSet` ms at each goal, then picks the next (seeded);
* tracking deviation = |steering bar - target bar| (m), capped at `maxDeviation` if set;
* the **traffic light** above the bar lights red or green (equal odds) after a pause drawn
  in [lightMinPause, lightMaxPause] for `lightDuration` or until answered: red ->
  brake pedal >= 0.5, green -> accelerator >= 0.5 is correct; the other pedal is an
  error; no answer is a miss; the reaction time runs from light onset to the pedal
  crossing 0.5 (to the physics step). The secondary (landmark search) task needs the
  landmark textures and is not simulated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..control.controllers import pure_pursuit_steering, speed_pedal
from ..sim.controls import DriverControls
from ..task import DrivingTask, load_task
from ..task.model_scene import Point
from ..task.model_taskxml import SteeringTask
from .base import OpenDSEnv
from .config import EnvConfig

PEDAL_THRESHOLD = 0.5
LIGHT_OFF, LIGHT_RED, LIGHT_GREEN = 0.0, 1.0, 2.0


@dataclass(frozen=True)
class ConTReConfig(EnvConfig):
    task: str = "ConTRe"
    max_episode_s: float = 120.0
    steering_gain: float = 1.0
    deviation_reward_scale: float = 0.1


class ConTReEnv(OpenDSEnv):
    """ConTRe (Continuous Tracking and Reaction) on the bundled OpenDS ConTRe task: keep a
    steering bar on a moving target bar while the car drives itself, and answer a red/green
    light above the bar with the brake (red) or the accelerator (green). Rules and
    parameters: `opends_gym.envs.contre` module docstring.

    ## Action space
    Default `continuous`: Box(-1, 1, (2,)): [steering moves the steering bar (+ left),
    pedal (+ accelerator answers green, - brake answers red)].

    ## Observation space
    `kinematics` plus `target_bar_m`, `steering_bar_m`, `deviation_m`, `light` (0 off,
    1 red, 2 green).

    ## Reward
    -`deviation_reward_scale` x mean deviation (m) per step, +1 per correct light reaction,
    -1 per error or miss.

    ## Episode end
    Truncated after `max_episode_s` (120 s; the task's track would take ~10 min); terminated
    when the car reaches the end of the track or the task shuts down.

    ## Info
    `OpenDSEnv`'s keys plus `contre_deviation_m` (current); `episode_metrics` adds
    `tracking_deviation_mean_m`, `tracking_deviation_rms_m`, `lights`, `lights_correct`,
    `light_errors`, `light_misses`, `light_mean_rt_s`.

    ## Version history
    v0: initial release.
    """

    config_class = ConTReConfig
    stimulus_names = ("target_bar_m", "steering_bar_m", "deviation_m", "light")

    def _make_task(self) -> DrivingTask:
        return load_task(self.config.task)  # type: ignore[attr-defined]

    def _setup(self) -> None:
        st = self.task.task.steering_task if self.task.task else None
        assert st is not None and st.target_object is not None and st.steering_object is not None, "the task has no ConTRe steeringTask"
        self.contre: SteeringTask = st
        self.target_speed: float = 0.0
        flight = self.task.scenario.driver.camera_flight
        points = {g.id: g.translation_m for g in self.task.scene.geometries if isinstance(g, Point)}
        track = [p.translation_m or points[p.ref] for p in (flight.track if flight else ())]
        self.track_x = float(np.median([p[0] for p in track])) if track else self.task.start_pose.position_m[0]
        self.end_z = min(p[2] for p in track) if track else -1e9
        self.speed_mps = flight.speed_mps if flight else 50 / 3.6
        self.world.triggers.add_action_handler("setupContreTask", self._set_target_speed)

    def _set_target_speed(self, args: dict[str, Any]) -> None:
        self.target_speed = float(args.get("target_object_speed", self.target_speed))

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        self.rng = np.random.default_rng(int(self.np_random.integers(0, 2**31 - 1)))
        t, s = self.contre.target_object, self.contre.steering_object
        assert t is not None and s is not None
        self.target_speed = t.speed
        self.target_l = 0.0
        self.steer_l = 0.0
        self.goal_l = self._new_goal()
        self.pause_until = 0.0
        p = self.contre.primary_task
        self.light = LIGHT_OFF
        self.light_on_s = 0.0
        self.next_light_s = self._pause(p)
        self.lights: list[tuple[float, float, int]] = []  # (colour, reaction time s, result)
        self.deviations: list[float] = []
        self._held = (False, False)
        self._agent = DriverControls()
        self._reward_acc = 0.0

    def _new_goal(self) -> float:
        t = self.contre.target_object
        assert t is not None
        return float(self.rng.uniform(-t.max_right_m, t.max_left_m))

    def _pause(self, p: Any) -> float:
        if p is None:
            return math.inf
        return self.world.t_s + float(self.rng.uniform(p.light_min_pause_s, p.light_max_pause_s))

    # the car drives itself; the agent's inputs steer the bar and answer the lights
    def _transform_controls(self, controls: DriverControls) -> DriverControls:
        self._agent = controls
        s = self.world.ego.state
        p = self.guide.locate(s.x, s.z)
        # the task has no lanes: the guide's reference is the car's start line, which is
        # the camera-flight track (x = track_x along -Z)
        steer = pure_pursuit_steering(s.yaw, p.heading_rad, p.lateral_m, 0.0, 8.0)
        pedal = speed_pedal(s.u, self.speed_mps)
        return DriverControls(steering=steer, accelerator=max(pedal, 0.0), brake=max(-pedal, 0.0))

    def _on_physics_step(self) -> None:
        w = self.world
        dt = w.dt_s
        t, so = self.contre.target_object, self.contre.steering_object
        assert t is not None and so is not None
        # steering bar
        self.steer_l = min(so.max_left_m, max(-so.max_right_m, self.steer_l + self._agent.steering * so.speed * dt))
        # target bar
        if w.t_s >= self.pause_until:
            step = self.target_speed * dt
            d = self.goal_l - self.target_l
            if abs(d) <= step:
                self.target_l = self.goal_l
                self.goal_l = self._new_goal()
                self.pause_until = w.t_s + (self.contre.pause_after_target_set_s or 0.0)
            else:
                self.target_l += math.copysign(step, d)
        dev = abs(self.steer_l - self.target_l)
        if self.contre.max_deviation_m is not None:
            dev = min(dev, self.contre.max_deviation_m)
        self.deviations.append(dev)
        self._reward_acc -= self.config.deviation_reward_scale * dev / self.config.action_repeat  # type: ignore[attr-defined]
        self._lights()
        self._place_objects()

    def _lights(self) -> None:
        w = self.world
        p = self.contre.primary_task
        gas = self._agent.accelerator >= PEDAL_THRESHOLD
        brake = self._agent.brake >= PEDAL_THRESHOLD
        rising_gas, rising_brake = gas and not self._held[0], brake and not self._held[1]
        self._held = (gas, brake)
        if self.light == LIGHT_OFF:
            if w.t_s >= self.next_light_s and p is not None:
                self.light = LIGHT_RED if self.rng.random() < 0.5 else LIGHT_GREEN
                self.light_on_s = w.t_s
                w.events.emit(w.t_s, "stimulus", "contre_light", colour="red" if self.light == LIGHT_RED else "green")
            return
        assert p is not None
        result = 0
        if rising_gas or rising_brake:
            correct = (self.light == LIGHT_GREEN and rising_gas) or (self.light == LIGHT_RED and rising_brake)
            result = 1 if correct else -1
        elif w.t_s - self.light_on_s >= p.light_duration_s:
            result = -2
        if result:
            rt = w.t_s - self.light_on_s if result != -2 else 10.0
            self.lights.append((self.light, rt, result))
            w.events.emit(w.t_s, "reaction", "contre_light", result=result, reaction_time_s=rt)
            self._reward_acc += 1.0 if result == 1 else -1.0
            self.light = LIGHT_OFF
            self.next_light_s = self._pause(p)

    def _place_objects(self) -> None:
        """Keep the bars and the light box `distanceToObjects` ahead of the car for the viewer."""
        s = self.world.ego.state
        z = s.z - self.contre.distance_to_objects_m
        for oid, lat in (
            (self.contre.steering_object.id if self.contre.steering_object else "", self.steer_l),
            (self.contre.target_object.id if self.contre.target_object else "", self.target_l),
        ):
            for o in self.world.objects.by_id.get(oid, ()):
                o.position = (self.track_x - lat, o.position[1], z)
        light_id = self.contre.traffic_light_object_id or ""
        for o in self.world.objects.by_id.get(light_id, ()):
            o.position = (self.track_x - self.target_l, self.contre.height_offset_m, z)
            o.visible = self.light != LIGHT_OFF

    def _stimulus(self) -> list[float]:
        return [self.target_l, self.steer_l, abs(self.steer_l - self.target_l), self.light]

    def _reward(self, info: dict[str, Any]) -> float:
        r, self._reward_acc = self._reward_acc, 0.0
        return r

    def _task_info(self, info: dict[str, Any]) -> None:
        info["contre_deviation_m"] = abs(self.steer_l - self.target_l)

    def _task_terminated(self) -> bool:
        return self.world.ego.state.z <= self.end_z

    def _off_road_at(self, lateral_m: float) -> bool:
        return False  # the car drives itself along the track (the agent steers the bar)

    def _stimuli_presented(self) -> int:
        """Lights shown (answered, missed or still on)."""
        return len(self.lights) + (1 if self.light != LIGHT_OFF else 0)

    def _episode_metrics(self) -> dict[str, float]:
        dev = np.asarray(self.deviations)
        correct = [rt for _, rt, r in self.lights if r == 1]
        return {
            "tracking_deviation_mean_m": float(dev.mean()) if len(dev) else math.nan,
            "tracking_deviation_rms_m": float(np.sqrt(np.mean(dev**2))) if len(dev) else math.nan,
            "lights": float(len(self.lights)),
            "lights_correct": float(len(correct)),
            "light_errors": float(sum(1 for _, _, r in self.lights if r == -1)),
            "light_misses": float(sum(1 for _, _, r in self.lights if r == -2)),
            "light_mean_rt_s": float(np.mean(correct)) if correct else math.nan,
        }
