"""`OpenDS/ThreeVehiclePlatoon-v0`: the Three-Vehicle Platoon Task (TVPT)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..sim.perception import lead_vehicle
from ..task import DrivingTask
from .base import OpenDSEnv
from .config import EnvConfig
from .platoon_core import PlatoonCore
from .platoon_task import PlatoonGeometry, build_platoon_task

_GEOMETRY = {f.name for f in dataclasses.fields(PlatoonGeometry)} - {"kinds", "follower"}


@dataclass(frozen=True)
class PlatoonConfig(EnvConfig):
    max_episode_s: float = 300.0
    lane_width_m: float = 3.75
    speed_kmh: float = 80.0
    stimuli: int = 10
    spacing_min_m: float = 250.0
    spacing_max_m: float = 400.0
    lead_in_m: float = 300.0
    lead_out_m: float = 300.0
    lead_gap_m: float = 30.0
    follower_gap_m: float = 10.0
    track_seed: int = 1
    action: str = "continuous_buttons"
    reward_progress_per_m: float = 0.1
    reward_deviation_per_m: float = 0.01
    reward_deviation_cap_m: float = 10.0
    off_road_margin_m: float = 1.5
    off_road_penalty: float = 50.0
    collision_penalty: float = 50.0
    end_when_past_lead: bool = True
    reward_ttc_weight: float = 0.0
    reward_ttc_threshold_s: float = 3.0


class ThreeVehiclePlatoonEnv(OpenDSEnv):
    """The Three-Vehicle Platoon Task: drive between a leading car (kept 20-50 m ahead) and
    a follower (5-15 m behind) on a two-lane road at ~80 km/h, hold the longitudinal
    (20-35 m to the lead) and lateral (-2..3 m) tolerance bands, and react within 5 s to
    stimuli: the lead's brake light (brake), a turn signal of the lead or the follower
    (press the reaction button or indicate), a speed reduction of the lead to 50 km/h
    (slow down) and an emergency brake of the lead (brake). Parameters come from the
    task's `task.xml` (the defaults are OpenDS-CTS's TVPT values); the stimulus rules are
    documented in `opends_gym.envs.platoon_core`.

    ## Action space
    Default `continuous_buttons`: Box(-1, 1, (6,)): steering, pedal, then buttons
    reaction, horn, left and right indicator (> 0 = held).

    ## Observation space
    `kinematics` plus `lead_gap_m`, `lead_rel_speed_mps`, `lead_brake_light`,
    `lead_turn_signal`, `follower_gap_m`, `follower_turn_signal` (turn signal codes
    0 off, 1 left, 2 right, 3 both).

    ## Reward
    `reward_progress_per_m` (0.1) per metre driven, minus `reward_deviation_per_m` (0.01)
    x the longitudinal + lateral deviation outside the bands (m, capped at
    `reward_deviation_cap_m` = 10 m) per step; +1 per correct reaction, -1 per miss,
    -`collision_penalty` (50) per collision, -`off_road_penalty` (50) for leaving the
    road or passing the lead car. Optional time-to-collision shaping:
    -`reward_ttc_weight` x (1 - TTC / `reward_ttc_threshold_s`) per step while the TTC to
    the lead is below the threshold (weight 0 here, so off; the brake test turns it on).
    At the platoon's speed the progress term (+0.22 per step) outweighs the largest
    deviation penalty (-0.1 per step), so driving on always pays more than crashing or
    stopping.

    ## Episode end
    Terminated at the end of the track (the task pauses the simulation), on a collision
    (`on_collision="terminate"`, the default; `recover` puts the car back at rest clear of
    what it hit, see `opends_gym.envs.collision`),
    when the car leaves the road by more than `off_road_margin_m` (1.5 m; with
    `on_road_exit="terminate"`, the default, see `opends_gym.envs.road_exit`), or, with
    `end_when_past_lead` (default), when it draws level with the lead car (overtaking
    voids the test; both count as leaving the task and cost `off_road_penalty`);
    truncated after `max_episode_s` (300 s).

    ## Info
    `OpenDSEnv`'s keys; `episode_metrics` adds longitudinal/lateral deviation (mean m,
    max m, fraction of time outside the band), per stimulus kind `<kind>_n`,
    `<kind>_misses`, `<kind>_mean_rt_s`, and `stimuli`, `stimulus_misses`,
    `stimulus_mean_rt_s` (a miss: no reaction within `maxReactionTime`, also when the
    stimulus itself ended sooner, as the 2.5 s brake light does).

    ## Version history
    v0: initial release.
    """

    config_class = PlatoonConfig
    stimulus_names: ClassVar[tuple[str, ...]] = (
        "lead_gap_m",
        "lead_rel_speed_mps",
        "lead_brake_light",
        "lead_turn_signal",
        "follower_gap_m",
        "follower_turn_signal",
    )
    with_follower = True

    def geometry(self) -> PlatoonGeometry:
        return PlatoonGeometry(**{k: getattr(self.config, k) for k in _GEOMETRY})

    def _make_task(self) -> DrivingTask:
        return build_platoon_task(self.geometry())

    def _setup(self) -> None:
        spec = self.task.task.three_vehicle_platoon if self.task.task else None
        assert spec is not None, "the task has no threeVehiclePlatoon block"
        self.platoon = PlatoonCore(self.world, spec, None, with_follower=self.with_follower)
        self.world.triggers.add_action_handler("setTVPTStimulus", lambda args: self.platoon.handle_action(args))
        self._reward_acc = 0.0

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        self.platoon.reset(np.random.default_rng(int(self.np_random.integers(0, 2**31 - 1))))
        self._reward_acc = 0.0
        self._seen_results = 0

    def _on_physics_step(self) -> None:
        c = self.controls
        inp = self.world.ego.inputs
        pressed = bool(c.keys or c.buttons)
        gas, brake = self.driver_pedals()  # (not the full brake of a hold after a reset)
        self.platoon.step(gas, brake, pressed, inp.turn_signal, self.trace.last("lane_offset_m"))
        if self.on_collision == "recover" and self.config.end_when_past_lead and self._past_lead():  # type: ignore[attr-defined]
            self._put_behind_lead()
        st = self.platoon.state
        if st.lon_dev:
            cfg = self.config
            dev = min(st.lon_dev[-1] + (st.lat_dev[-1] if st.lat_dev else 0.0), cfg.reward_deviation_cap_m)  # type: ignore[attr-defined]
            self._reward_acc -= cfg.reward_deviation_per_m * dev / cfg.action_repeat  # type: ignore[attr-defined]
        if self.config.reward_ttc_weight > 0.0:  # type: ignore[attr-defined]
            self._reward_acc -= self._ttc_penalty(self.trace.last("ttc_s"))

    def _ttc_penalty(self, ttc_s: float) -> float:
        """Per physics step: grows linearly from 0 at the threshold to the weight at TTC 0."""
        cfg: Any = self.config
        return cfg.reward_ttc_weight * max(0.0, 1.0 - ttc_s / cfg.reward_ttc_threshold_s) / cfg.action_repeat

    def _stimulus(self) -> list[float]:
        traffic = self.world.traffic
        assert traffic is not None
        lead = lead_vehicle(self.world)
        li = traffic.index_of(self.platoon.lead)
        fi = traffic.index_of(self.platoon.follower)
        follower_gap = -(self.platoon._distance_to(self.platoon.follower) or 0.0) if self.with_follower else 0.0
        return [
            lead.gap_m if lead is not None else 0.0,
            (lead.speed_mps - self.world.ego.state.u) if lead is not None else 0.0,
            float(traffic.brake_light[li]),
            float(traffic.turn_signal[li]),
            follower_gap,
            float(traffic.turn_signal[fi]) if self.with_follower else 0.0,
        ]

    def _off_road_at(self, lateral_m: float) -> bool:
        cfg: Any = self.config
        half_road = len(self.world.road.lanes) * cfg.lane_width_m / 2
        return abs(lateral_m) > half_road + cfg.off_road_margin_m

    def _off_road_mask(self, lateral_m: np.ndarray) -> np.ndarray:
        cfg: Any = self.config
        half_road = len(self.world.road.lanes) * cfg.lane_width_m / 2
        return np.abs(np.asarray(lateral_m, dtype=np.float64)) > half_road + cfg.off_road_margin_m

    def _task_terminated(self) -> bool:
        """Passing the lead ends the test, except under `on_collision="recover"`, where
        `_on_physics_step` has already put the car back behind it."""
        if self.on_collision == "recover":
            return False
        return bool(self.config.end_when_past_lead) and self._past_lead()  # type: ignore[attr-defined]

    def _stimuli_presented(self) -> int:
        return len(self.platoon.state.stimuli)

    def _put_behind_lead(self) -> None:
        """`on_collision="recover"` (a study's exposure, not survival): passing the lead car
        voids OpenDS's test; here the car is put back behind the lead car, in its lane, at
        rest and held, as after a collision (`envs.collision`), and the drive goes on."""
        traffic = self.world.traffic
        assert traffic is not None
        lead = traffic.positions[traffic.index_of(self.platoon.lead)]
        lx, lz = float(lead[0]), float(lead[2])
        lateral = self.guide.locate(lx, lz).lateral_m
        laterals = self.guide.lane_laterals_m
        lane = min(range(len(laterals)), key=lambda i: abs(laterals[i] - lateral))
        self._reset_to_lane(behind=(lx, lz, lane))

    def _past_lead(self) -> bool:
        """The ego's centre is level with or ahead of the lead car's: overtaking it voids the test.
        Measured along the ego's heading (`on_road_exit="terminate"`, as the native batch) or,
        where the car may leave the road and come back, along the road: a car spun round
        beside the road has not passed the lead."""
        if self.on_road_exit == "terminate":
            d = self.platoon._distance_to(self.platoon.lead)
            return d is not None and d < 0.0
        traffic = self.world.traffic
        assert traffic is not None
        lead = traffic.positions[traffic.index_of(self.platoon.lead)]
        s = self.world.ego.state
        return self.guide.locate(float(lead[0]), float(lead[2])).s_m - self.guide.locate(s.x, s.z).s_m < 0.0

    def _reward(self, info: dict[str, Any]) -> float:
        cfg = self.config
        r = self._reward_acc + cfg.reward_progress_per_m * max(0.0, float(info["progress_m"]))  # type: ignore[attr-defined]
        self._reward_acc = 0.0
        left_task = self._exits_this_step + (1 if self._task_terminated() else 0)
        r -= cfg.off_road_penalty * min(left_task, 1)  # type: ignore[attr-defined]
        results = [s.result for s in self.platoon.state.stimuli if s.result != 0]
        for res in results[self._seen_results :]:
            r += 1.0 if res == 1 else -1.0
        self._seen_results = len(results)
        return r - cfg.collision_penalty * float(info["new_collisions"])  # type: ignore[attr-defined]

    def _episode_metrics(self) -> dict[str, float]:
        return self.platoon.metrics()
