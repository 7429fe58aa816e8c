"""`OpenDS/LaneChangeTest-v0`: the ISO 26022-style Lane Change Test."""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..metrics.lct import LctSign, NormativeModel, fit_lane_changes, lct_mdev, normative_path
from ..metrics.lct_iso import score_lct_iso
from ..sim.controls import STEERING_WHEEL_MAX_DEG
from ..task import DrivingTask
from .base import OpenDSEnv
from .config import EnvConfig
from .lct_task import LctGeometry, LctSignSpec, build_lct_task, sign_sequence
from .trace import COL

_GEOMETRY_FIELDS = {f.name for f in dataclasses.fields(LctGeometry)}
SCORINGS = ("default", "iso26022")
_Z, _LAT = COL["z_m"], COL["lateral_m"]


@dataclass(frozen=True)
class LaneChangeTestConfig(EnvConfig):
    max_episode_s: float = 300.0
    lanes: int = 3
    lane_width_m: float = 3.85
    speed_kmh: float = 60.0
    signs: int = 18
    spacing_min_m: float = 140.0
    spacing_max_m: float = 190.0
    visibility_m: float = 40.0
    lead_in_m: float = 200.0
    lead_out_m: float = 200.0
    start_z_m: float = 0.0
    track_seed: int = 1
    hold_lane_s: float = 1.0
    normative_start_before_sign_m: float = 30.0
    normative_length_per_lane_m: float = 40.0
    off_road_margin_m: float = 1.5
    reward_scale: float = 0.1
    reward_deviation_scale_m: float = 2.0
    off_road_penalty: float = 10.0
    scoring: str = "default"

    def geometry(self) -> LctGeometry:
        return LctGeometry(**{k: getattr(self, k) for k in _GEOMETRY_FIELDS})


class LaneChangeTestEnv(OpenDSEnv):
    """ISO 26022-style Lane Change Test: a straight three-lane road at a fixed 60 km/h;
    pairs of signs, revealed `visibility_m` (40 m) ahead of the driver, tell which lane to
    drive in. The drive is scored by the mean deviation (MDEV) of the lateral position
    from a normative path: the basic model (lane change from `normative_start_before_sign_m`
    before the sign over `normative_length_per_lane_m`) and the adapted model fitted to the
    driver's own lane changes (see `opends_gym.metrics.lct`). Track geometry defaults and
    their sources are in `opends_gym.envs.lct_task`; the bundled `tasks/LaneChangeTest` is
    the default track.

    ## Action space
    Default `continuous`: Box(-1, 1, (2,)): [steering (+ left), pedal]. The speed is held
    at 60 km/h by the car (engine min = max speed), as in the ISO test with the pedal
    floored; braking still slows the car.

    ## Observation space
    Default `kinematics` (see `DrivingTaskEnv`) plus three stimulus slots:
    `sign_visible` (0/1), `instructed_lane_offset_m` (lateral position of the instructed
    lane's centre relative to the car, m, + left), `sign_distance_m` (to the revealed
    sign ahead, 0 when none).

    ## Reward
    `reward_scale` x the metres driven in the step, each weighted by
    max(0, 1 - deviation / `reward_deviation_scale_m`) where deviation is the lateral
    distance from the basic normative path (so a perfect drive of the ~3200 m track earns
    ~320 and leaving the normative path earns nothing); -`off_road_penalty` when the car
    leaves the road, -10 per collision. Positive per-metre reward keeps "end the episode
    early" from ever paying.

    ## Episode end
    Terminated when the car reaches the end of the track (the task pauses the simulation),
    leaves the road by more than `off_road_margin_m` (with `on_road_exit="terminate"`, the
    default; `recover` puts the car back on its lane, `continue` drives on, see
    `opends_gym.envs.road_exit`), or collides; truncated after `max_episode_s` (300 s; the
    track takes ~195 s).

    ## Info
    The keys of `OpenDSEnv`; `mean_deviation_m` is the running MDEV against the basic
    model. `episode_metrics` adds: mdev_basic_m, mdev_adapted_m, the adapted model's
    parameters, lane_changes (signs passed), lane_changes_correct (target lane reached),
    lane_change_errors, mean_lane_change_latency_s (sign visible to start of the move),
    the exposure (`OpenDSEnv`'s plus signs_reached: signs the car drove past;
    stimuli_presented counts the signs revealed; after resets each stretch of road is
    scored once, up to where the car left it),
    and per sign `sign07_latency_s`, `sign07_reached`, `sign07_timer_result` (OpenDS's
    lane-change reaction timer: 1 correct, -1 failure, -2 missed, 0 not armed).
    SDLP (`sdlp_j2944_m`) leaves out the instructed lane changes (from a sign becoming
    readable to the end of the basic normative change) and is taken relative to the
    instructed lane; the reversal rates count those lane-keeping stretches only.

    With `scoring="iso26022"`, `episode_metrics` also holds the ISO 26022-style scores of
    `opends_gym.metrics.lct_iso` (lead-in and lead-out not scored): iso_mdev_m,
    iso_mdev_lane_change_m, iso_mdev_lane_keeping_m, iso_scored_m, iso_signs_scored,
    iso_correct, iso_wrong_lane, iso_missed, iso_mean_latency_s, iso_median_latency_s
    (sign readable to steering onset) and per sign `sign07_iso_result` (1 correct, -1
    wrong lane, -2 missed), `sign07_iso_mdev_m`, `sign07_iso_mdev_lane_change_m`,
    `sign07_iso_mdev_lane_keeping_m`, `sign07_iso_latency_s`. See docs/metrics.md.

    ## Arguments
    Every `EnvConfig` field (physics, policy_hz, observation, action, ...) and the track:
    lanes, lane_width_m, speed_kmh, signs, spacing_min_m, spacing_max_m, visibility_m,
    lead_in_m, lead_out_m, track_seed, hold_lane_s, normative_start_before_sign_m,
    normative_length_per_lane_m, off_road_margin_m, reward_scale, reward_deviation_scale_m,
    off_road_penalty, and `scoring` ("default" or "iso26022").

    ## Version history
    v0: initial release.
    """

    config_class = LaneChangeTestConfig
    stimulus_names = ("sign_visible", "instructed_lane_offset_m", "sign_distance_m")

    def _make_task(self) -> DrivingTask:
        assert isinstance(self.config, LaneChangeTestConfig)
        self.geometry = self.config.geometry()
        return build_lct_task(self.geometry)

    def _setup(self) -> None:
        g = self.geometry
        scoring = getattr(self.config, "scoring", "default")
        if scoring not in SCORINGS:
            raise ValueError(f"LaneChangeTestConfig.scoring must be one of {', '.join(SCORINGS)}, not {scoring!r}")
        self.sign_specs: list[LctSignSpec] = sign_sequence(g)
        # distance along the track of each sign (the guide measures s from the start)
        self.metric_signs = [LctSign(g.start_z_m - s.z_m, s.from_lane, s.to_lane) for s in self.sign_specs]
        self.lane_laterals = list(self.guide.lane_laterals_m)
        self.initial_lane = g.lanes // 2
        self.basic = NormativeModel(g.normative_start_before_sign_m, g.normative_length_per_lane_m)
        self._sign_models = [self.world.objects.by_id[f"LCT_Sign{s.index:02d}_Left"][0] for s in self.sign_specs]
        # the normative path tabulated every 0.05 m: one lookup per physics step
        length = self.metric_signs[-1].d_m + g.lead_out_m + 50.0
        self._norm_step = 0.05
        d = np.arange(-20.0, length, self._norm_step)
        self._norm_d0 = float(d[0])
        self._norm = normative_path(d, self.metric_signs, self.lane_laterals, self.initial_lane, self.basic).tolist()
        self.half_road = g.lanes * g.lane_width_m / 2
        cfg: Any = self.config  # (frozen: the per-step limits are read once)
        self._off_road_m = self.half_road + cfg.off_road_margin_m
        self._deviation_scale = cfg.reward_deviation_scale_m
        self._start_z = float(self.world.task.start_pose.position_m[2])  # (a scene lookup: not per step)

    def _norm_at(self, d: float) -> float:
        i = int((d - self._norm_d0) / self._norm_step)
        table = self._norm
        return table[0] if i < 0 else table[-1] if i >= len(table) else table[i]

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        self._area = 0.0
        self._step_reward = 0.0
        self._prev: tuple[float, float] | None = None

    def _on_physics_step(self) -> None:
        row = self.trace.last_row()  # (this runs every physics step: one row lookup, no names)
        d = self._start_z - row[_Z]
        dev = abs(row[_LAT] - self._norm_at(d))
        if self._prev is not None:
            d0, dev0 = self._prev
            self._area += 0.5 * (dev + dev0) * (d - d0)
            self._step_reward += max(0.0, 1.0 - 0.5 * (dev + dev0) / self._deviation_scale) * (d - d0)
        self._prev = (d, dev)

    def _active_sign(self) -> LctSignSpec | None:
        """The last visible sign (searched from the end: asked every policy step)."""
        for spec, model in zip(reversed(self.sign_specs), reversed(self._sign_models)):
            if model.visible:
                return spec
        return None

    def _stimulus(self) -> list[float]:
        s = self.world.ego.state
        lat = self.guide.locate(s.x, s.z).lateral_m
        sign = self._active_sign()
        lane = sign.to_lane if sign is not None else self.initial_lane
        distance = max(0.0, s.z - sign.z_m) if sign is not None else 0.0
        visible = 1.0 if sign is not None and distance > 0.0 else 0.0
        return [visible, self.lane_laterals[lane] - lat, distance]

    def _reward(self, info: dict[str, Any]) -> float:
        r = self.config.reward_scale * self._step_reward  # type: ignore[attr-defined]
        self._step_reward = 0.0
        r -= self.config.off_road_penalty * self._exits_this_step  # type: ignore[attr-defined]
        return r - 10.0 * float(info["new_collisions"])

    def _task_info(self, info: dict[str, Any]) -> None:
        dist = self._prev[0] if self._prev else 0.0
        info["mean_deviation_m"] = self._area / dist if dist > 0 else 0.0

    def _off_road(self) -> bool:
        row = self.trace.last_row()  # (every physics step: no name lookups)
        return bool(row) and abs(row[_LAT]) > self._off_road_m

    def _off_road_at(self, lateral_m: float) -> bool:
        return abs(lateral_m) > self._off_road_m

    def _off_road_mask(self, lateral_m: np.ndarray) -> np.ndarray:
        return np.abs(lateral_m) > self._off_road_m  # (`_off_road_at` over the trace in one operation)

    def _after_reset_position(self) -> None:
        self._prev = None  # the deviation integral restarts at the lane position

    def _stimuli_presented(self) -> int:
        """Signs revealed: the car came within `visibility_m` of them."""
        d = self._furthest_m()
        return sum(1 for s in self.metric_signs if d >= s.d_m - self.geometry.visibility_m)

    def _furthest_m(self) -> float:
        z = self.trace.col("z_m")
        return float(self._start_z - np.min(z)) if len(z) else 0.0

    def _episode_metrics(self) -> dict[str, float]:
        tr = self.trace
        g = self.geometry
        d = float(self.world.task.start_pose.position_m[2]) - tr.col("z_m")
        y = tr.col("lateral_m")
        t, steer = tr.col("t_s"), tr.col("steering") * STEERING_WHEEL_MAX_DEG
        if self.resets:  # score each stretch of road once: the drive up to each exit, not the re-drive after the reset
            first = d >= np.maximum.accumulate(d)
            d, y, t, steer = d[first], y[first], t[first], steer[first]
        passed = [s for s in self.metric_signs if s.d_m <= d[-1]]
        furthest = self._furthest_m()
        out: dict[str, float] = {"signs_reached": float(sum(1 for s in self.metric_signs if s.d_m <= furthest))}
        fits = fit_lane_changes(d, y, passed, self.lane_laterals, g.visibility_m) if passed else []
        if len(d) > 1 and passed:
            out.update(lct_mdev(d, y, passed, self.lane_laterals, self.initial_lane, self.basic, g.visibility_m, fits))
        else:
            out.update({"mdev_basic_m": math.nan, "mdev_adapted_m": math.nan})
        timer = self._timer_results()
        latencies = []
        for k, f in enumerate(fits):
            latency_s = f.latency_m / (g.speed_kmh / 3.6) if math.isfinite(f.latency_m) else math.nan
            if math.isfinite(latency_s):
                latencies.append(latency_s)
            out[f"sign{k:02d}_latency_s"] = latency_s
            out[f"sign{k:02d}_reached"] = float(f.reached_target)
            out[f"sign{k:02d}_timer_result"] = float(timer.get(k, 0))
        correct = sum(1 for f in fits if f.reached_target)
        out["lane_changes"] = float(len(fits))
        out["lane_changes_correct"] = float(correct)
        out["lane_change_errors"] = float(len(fits) - correct)
        out["mean_lane_change_latency_s"] = float(np.mean(latencies)) if latencies else math.nan
        if self.config.scoring == "iso26022":  # type: ignore[attr-defined]
            iso = score_lct_iso(d, t, y, steer, passed, self.lane_laterals, self.initial_lane, self.basic, g.visibility_m)
            out.update(iso.as_dict())
        return out

    def _instructed_changes(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per sample at distances `d`: inside an instructed lane change (from its sign
        becoming readable to the end of the basic normative change), and the instructed
        lane (the last readable sign's; the initial lane before the first)."""
        g = self.geometry
        changing = np.zeros(len(d), dtype=bool)
        lane = np.full(len(d), self.initial_lane, dtype=np.int64)
        furthest = float(np.max(d)) if len(d) else -math.inf  # (NaN: no sign skipped)
        for sign in self.metric_signs:  # (in track order)
            start = sign.d_m - g.visibility_m
            if start > furthest:  # not readable yet anywhere in the trace: changes nothing (short episodes stop here)
                continue
            end = sign.d_m - self.basic.start_before_sign_m + self.basic.length_per_lane_m * abs(sign.to_lane - sign.from_lane)
            changing |= (d >= start) & (d <= max(start, end))
            lane[d >= start] = sign.to_lane
        return changing, lane

    def _instructed_lane_keeping(self) -> np.ndarray | None:
        d = self._start_z - self.trace.col("z_m")
        return ~self._instructed_changes(d)[0]

    def _sdlp_lateral(self) -> np.ndarray:
        tr = self.trace
        lane = self._instructed_changes(self._start_z - tr.col("z_m"))[1]
        return tr.col("lateral_m") - np.asarray(self.lane_laterals)[lane]

    def _timer_results(self) -> dict[int, int]:
        """OpenDS lane-change timer results by sign index (parsed from the timer comment)."""
        out: dict[int, int] = {}
        for r in getattr(self.world.triggers, "reactions", ()):
            m = re.match(r"sign (\d+):", getattr(r, "comment", "") or "")
            if m:
                out[int(m.group(1))] = int(r.result)
        return out
