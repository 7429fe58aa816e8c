"""`OpenDS/DrivingTask-v0`: any OpenDS driving task as a Gymnasium environment."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..task import DrivingTask, load_task
from .base import OpenDSEnv
from .config import EnvConfig


@dataclass(frozen=True)
class DrivingTaskConfig(EnvConfig):
    task: str = "ReactionTest"  # a task folder, entry file or bundled task name


class DrivingTaskEnv(OpenDSEnv):
    """Drive any OpenDS task (folder, entry file or bundled name) with the task's own
    triggers, traffic and measurements.

    ## Action space
    Chosen by `action=` (default `continuous`): Box(-1, 1, (2,)) float32 =
    [steering (+ left, full = 450 deg steering wheel, 0.5 rad front wheel),
    pedal (+ accelerator, - brake)]; `continuous_buttons` adds four buttons (reaction,
    horn, left and right indicator; > 0 = held, a press fires on the rising edge);
    `discrete` = Discrete(5) meta-actions (keep, lane left, lane right, faster, slower).

    ## Observation space
    `observation=` `kinematics` (default): float32 vector in SI units: speed m/s, heading
    error rad, lane offset m (+ left), lateral position m, lane index, steering, yaw rate
    rad/s, then `nearby_vehicles` x [present, ahead m, left m, relative speed m/s, brake
    light, turn signal]; `rays`: speed, heading error, lane offset, then `rays` ranges in m;
    `topdown` / `driver_view`: uint8 RGB images (`image_height` x `image_width` x 3).
    `road_preview_m=(10.0, 25.0, 50.0)` (none by default) appends to a vector observation, per
    distance d, the road's heading d m ahead relative to the car's (rad, + left) and that
    point's lateral position in the car's frame (m, + left): the far point of the two-point
    model of steering (Salvucci & Gray 2004).

    ## Reward
    Metres of progress along the road per step, minus 0.1 x |lane offset| m, minus 10 per
    collision.

    ## Episode end
    Terminated on a collision (`on_collision="terminate"`, the default; `recover` puts the
    car back clear of what it hit, see `opends_gym.envs.collision`), when the task shuts the
    simulation down or pauses it until resumed (OpenDS's end-of-experiment idiom).
    Truncated after `max_episode_s` simulated seconds (default 600).

    ## Info
    The keys of `OpenDSEnv` (module `opends_gym.envs.base`); `episode_metrics` on the
    last step adds the OpenDS ideal-track mean deviation (`ideal_track_mean_deviation_m`
    and its completeness status code) when the task has an ideal track.

    ## Arguments
    `task` plus every field of `EnvConfig`: physics ("fast" | "bullet"), physics_hz (60),
    policy_hz (10), observation, action, max_episode_s, nearby_vehicles, rays,
    ray_range_m, road_preview_m, image_width/height, render_width/height,
    terminate_on_collision, on_collision, on_road_exit, reset_hold_s.

    ## Version history
    v0: initial release.
    """

    config_class = DrivingTaskConfig

    def _make_task(self) -> DrivingTask:
        assert isinstance(self.config, DrivingTaskConfig)
        return load_task(self.config.task)

    def _episode_metrics(self) -> dict[str, float]:
        from ..metrics.deviation import Completeness, mean_deviation

        out: dict[str, Any] = {}
        tr = self.trace
        if tr.n < 2:
            return out
        path = list(zip(tr.col("x_m"), tr.col("z_m")))
        statuses = list(Completeness)
        for name, (line, width) in self.world.road.ideal_tracks.items():
            res = mean_deviation(path, line.xz, width)
            out[f"ideal_track_mean_deviation_m[{name}]"] = res.mean_deviation_m
            out[f"ideal_track_status[{name}]"] = float(statuses.index(res.status))
        return out
