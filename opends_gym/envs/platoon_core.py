"""Lead/follower vehicle stimuli and distance bands, shared by the platoon and brake tests.

Why: OpenDS's Three-Vehicle Platoon Task is closed source; its XML (`task.xml`
`threeVehiclePlatoon`) and the `setTVPTStimulus` action are public. We re-specify it
from them (OpenDS `ThreeVehiclePlatoonTask`; docs/opends-compatibility.md#task-layers):

* the leading and follower cars keep the ego inside their distance bands
  (`leadingCar@minDistance..maxDistance`, `followerCar@...`) by adjusting their speed;
* stimuli, fired by `setTVPTStimulus stimulusID=...` from the task's triggers:
  - `brakeLight`: the lead's brake light comes on for `brakeLight@minDuration` without
    braking; reaction = brake pedal >= 0.1;
  - `leadingCarTurnSignal` / `followerCarTurnSignal` (`turnSignal` picks one at random):
    indicator on for `turnSignal@duration`; reaction = the reaction button (key/joystick
    button) or the driver's own indicator;
  - `speedReduction`: the lead slows to a speed drawn in
    [targetSpeedMinRegular, targetSpeedMaxRegular] for `speedReduction@duration`;
    reaction = ego speed at or below that speed + 5 km/h for `minTimeAllConditionsMet`;
  - `emergencyBrake`: the lead brakes at its full deceleration to a speed in
    [targetSpeedMinEmergency, targetSpeedMaxEmergency]; reaction = brake pedal >= 0.1;
  every reaction must come within `maxReactionTime` or it is a miss; `resetOnReaction`
  ends the stimulus at the reaction;
* deviation = how far the distance to the lead (longitudinal) or the lateral offset from
  the lane centre lies outside its `deviationTolerance` band (m; 0 inside).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..sim.world import World
from ..task.model_taskxml import ThreeVehiclePlatoon

BRAKE_THRESHOLD = 0.1
REGULAR_SPEED_TOLERANCE_MPS = 5.0 / 3.6
BAND_GAIN = 0.15  # (m/s) of lead speed change per metre outside the band
FOLLOWER_GAIN_PER_S = 0.5  # follower: (m/s) faster per metre it lags behind the band centre
FOLLOWER_CATCH_UP_MPS = 5.0  # at most this much above the nominal speed


@dataclass
class Stimulus:
    kind: str
    onset_s: float
    end_s: float
    target_mps: float = 0.0
    car: str = ""
    reaction_s: float = math.nan  # time of the reaction (NaN until it happens)
    result: int = 0  # 1 correct, -2 missed, 0 running
    hold_since_s: float = math.nan

    @property
    def reaction_time_s(self) -> float:
        return self.reaction_s - self.onset_s if math.isfinite(self.reaction_s) else math.nan


@dataclass
class PlatoonState:
    stimuli: list[Stimulus] = field(default_factory=list)
    active: list[Stimulus] = field(default_factory=list)
    lon_dev: list[float] = field(default_factory=list)
    lat_dev: list[float] = field(default_factory=list)


class PlatoonCore:
    """Runs the platoon's band control and stimuli for one env (uses world.traffic)."""

    def __init__(self, world: World, spec: ThreeVehiclePlatoon, rng_source: Any, with_follower: bool = True) -> None:
        self.world = world
        self.spec = spec
        self.rng_source = rng_source
        self.with_follower = with_follower
        self.lead = spec.leading_car.id
        self.follower = spec.follower_car.id
        self.state = PlatoonState()
        self.nominal_mps = 80.0 / 3.6  # the platoon's speed: the ego's start speed (the task's cruise speed)

    # ------------------------------------------------------------------ setup
    def reset(self, rng: np.random.Generator) -> None:
        self.rng = rng
        self.state = PlatoonState()
        traffic = self.world.traffic
        assert traffic is not None, "the platoon needs traffic cars"
        for car in (self.lead, self.follower):
            traffic.set_speed_override(car, None)
            traffic.set_brake_light(car, None)
            traffic.set_turn_signal(car, None)
            # the platoon is already rolling at the ego's start speed (OpenDS traffic would
            # start at rest and be rear-ended), and its cars keep the task's bands rather
            # than OpenDS's speed-dependent safety distance (45 m at 90 km/h)
            traffic.set_speed(car, self.world.ego.state.u)
            traffic.set_safety_distance(car, forward_m=3.0, speed_dependent=False)
        self.nominal_mps = self.world.ego.state.u or self.nominal_mps

    def handle_action(self, args: dict[str, Any]) -> None:
        """`setTVPTStimulus` handler: start the named stimulus now."""
        kind = str(args.get("stimulus_id", ""))
        if kind == "turnSignal":
            kind = "leadingCarTurnSignal" if self.rng.random() < 0.5 or not self.with_follower else "followerCarTurnSignal"
        self.start(kind)

    def start(self, kind: str) -> Stimulus | None:
        spec, t = self.spec, self.world.t_s
        traffic = self.world.traffic
        assert traffic is not None
        st: Stimulus | None = None
        if kind == "brakeLight":
            st = Stimulus(kind, t, t + (spec.brake_light_min_duration_s or 2.5), car=self.lead)
            traffic.set_brake_light(self.lead, True)
        elif kind in ("leadingCarTurnSignal", "followerCarTurnSignal"):
            car = self.lead if kind.startswith("leading") else self.follower
            st = Stimulus(kind, t, t + (spec.turn_signal_duration_s or 2.5), car=car)
            traffic.set_turn_signal(car, "left")
        elif kind in ("speedReduction", "emergencyBrake"):
            sr = spec.speed_reduction
            if sr is None:
                return None
            if kind == "speedReduction":
                target = float(self.rng.uniform(sr.target_speed_min_regular_mps, sr.target_speed_max_regular_mps))
                st = Stimulus(kind, t, t + sr.duration_s, target_mps=target, car=self.lead)
                traffic.set_speed_override(self.lead, target)
            else:
                target = float(self.rng.uniform(sr.target_speed_min_emergency_mps, sr.target_speed_max_emergency_mps))
                decel = self.world.task.scenario.vehicles[traffic.index_of(self.lead)].deceleration_brake_mps2
                st = Stimulus(kind, t, t + sr.duration_s, target_mps=target, car=self.lead)
                traffic.set_speed_override(self.lead, target, decel)
        if st is None:
            self.world.events.emit(t, "warning", "setTVPTStimulus", message=f"unsupported stimulus {kind!r}")
            return None
        self.state.stimuli.append(st)
        self.state.active.append(st)
        self.world.events.emit(t, "stimulus", kind, car=st.car, target_kmh=st.target_mps * 3.6)
        return st

    # ------------------------------------------------------------------ step
    def step(self, accelerator: float, brake: float, reaction_pressed: bool, indicator: str, lateral_offset_m: float) -> None:
        w = self.world
        t = w.t_s
        self._hold_bands()
        for st in list(self.state.active):
            reacted = self._reacted(st, brake, reaction_pressed, indicator, t)
            if reacted and st.result == 0:
                st.reaction_s = t if st.kind != "speedReduction" else st.hold_since_s
                st.result = 1 if st.reaction_time_s <= self.spec.max_reaction_time_s + 1e-9 else -2
                w.events.emit(t, "reaction", st.kind, result=st.result, reaction_time_s=st.reaction_time_s)
                if self._reset_on_reaction(st):
                    self._end(st)
                    continue
            if st.result == 0 and t - st.onset_s > self.spec.max_reaction_time_s:
                st.result = -2
                w.events.emit(t, "reaction", st.kind, result=-2, reaction_time_s=10.0)
            if t >= st.end_s:
                self._end(st)
        lon = self._gap_to_lead()
        band = self.spec.longitudinal_tolerance
        if band is not None and lon is not None:
            self.state.lon_dev.append(max(0.0, band.lower_bound_m - lon, lon - band.upper_bound_m))
        lat_band = self.spec.lateral_tolerance
        if lat_band is not None:
            self.state.lat_dev.append(max(0.0, lat_band.lower_bound_m - lateral_offset_m, lateral_offset_m - lat_band.upper_bound_m))

    def _reacted(self, st: Stimulus, brake: float, reaction_pressed: bool, indicator: str, t: float) -> bool:
        if st.kind in ("brakeLight", "emergencyBrake"):
            return brake >= BRAKE_THRESHOLD
        if st.kind.endswith("TurnSignal"):
            return reaction_pressed or indicator in ("left", "right")
        if st.kind == "speedReduction":
            sr = self.spec.speed_reduction
            ok = self.world.ego.state.u <= st.target_mps + REGULAR_SPEED_TOLERANCE_MPS
            if not ok:
                st.hold_since_s = math.nan
                return False
            if not math.isfinite(st.hold_since_s):
                st.hold_since_s = t
            return sr is not None and t - st.hold_since_s >= sr.min_time_all_conditions_met_s - 1e-9
        return False

    def _reset_on_reaction(self, st: Stimulus) -> bool:
        spec = self.spec
        if st.kind == "brakeLight":
            return bool(spec.brake_light_reset_on_reaction)
        if st.kind.endswith("TurnSignal"):
            return bool(spec.turn_signal_reset_on_reaction)
        return bool(spec.speed_reduction and spec.speed_reduction.reset_on_reaction)

    def _end(self, st: Stimulus) -> None:
        traffic = self.world.traffic
        assert traffic is not None
        if st.kind == "brakeLight":
            traffic.set_brake_light(st.car, None)
        elif st.kind.endswith("TurnSignal"):
            traffic.set_turn_signal(st.car, None)
        else:
            traffic.set_speed_override(st.car, None)
        if st in self.state.active:
            self.state.active.remove(st)

    # ------------------------------------------------------------------ bands
    def _gap_to_lead(self) -> float | None:
        return self._distance_to(self.lead)

    def _distance_to(self, car: str) -> float | None:
        traffic = self.world.traffic
        if traffic is None:
            return None
        j = traffic.index_of(car)
        s = self.world.ego.state
        fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
        return float((traffic.positions[j, 0] - s.x) * fx + (traffic.positions[j, 2] - s.z) * fz)

    def _hold_bands(self) -> None:
        """Lead and follower adjust their speed to keep the ego inside their bands.

        The lead drives the platoon's nominal speed and only deviates when the ego is out
        of its band: slower by `BAND_GAIN` per metre beyond the far edge, faster per metre
        inside the near edge. (Keying the lead's speed to the ego's speed instead makes the
        two cars chase each other down to a standstill.) The follower keeps the centre of
        its band behind the ego like an adaptive cruise control, so it brakes when the ego
        brakes.
        """
        traffic = self.world.traffic
        assert traffic is not None
        busy = {st.car for st in self.state.active if st.kind in ("speedReduction", "emergencyBrake")}
        ego_v = self.world.ego.state.u
        lead_band, follow_band = self.spec.leading_car, self.spec.follower_car
        if self.lead not in busy:
            gap = self._distance_to(self.lead)
            target: float | None = None
            if gap is not None and gap > lead_band.max_distance_m:
                target = max(0.0, self.nominal_mps - BAND_GAIN * (gap - lead_band.max_distance_m))
            elif gap is not None and gap < lead_band.min_distance_m:
                target = self.nominal_mps + BAND_GAIN * (lead_band.min_distance_m - gap)
            traffic.set_speed_override(self.lead, target)
        if self.with_follower and self.follower not in busy:
            d = self._distance_to(self.follower)
            if d is not None:
                wanted = 0.5 * (follow_band.min_distance_m + follow_band.max_distance_m)
                target = ego_v + FOLLOWER_GAIN_PER_S * (-d - wanted)
                traffic.set_speed_override(self.follower, min(max(0.0, target), self.nominal_mps + FOLLOWER_CATCH_UP_MPS))

    # ------------------------------------------------------------------ metrics
    def metrics(self) -> dict[str, float]:
        out: dict[str, float] = {}
        lon = np.asarray(self.state.lon_dev)
        lat = np.asarray(self.state.lat_dev)
        out["longitudinal_deviation_mean_m"] = float(lon.mean()) if len(lon) else math.nan
        out["longitudinal_deviation_max_m"] = float(lon.max()) if len(lon) else math.nan
        out["longitudinal_outside_fraction"] = float(np.mean(lon > 0)) if len(lon) else math.nan
        out["lateral_deviation_mean_m"] = float(lat.mean()) if len(lat) else math.nan
        out["lateral_outside_fraction"] = float(np.mean(lat > 0)) if len(lat) else math.nan
        kinds = ("brakeLight", "leadingCarTurnSignal", "followerCarTurnSignal", "speedReduction", "emergencyBrake")
        # a stimulus that ended (brake light off after its 2.5 s) before any reaction stays
        # unscored (result 0) in the event log; once its reaction window is over it is a miss
        t_end, max_rt = self.world.t_s, self.spec.max_reaction_time_s

        def missed(st: Stimulus) -> bool:
            return st.result == -2 or (st.result == 0 and t_end - st.onset_s > max_rt)

        for kind in kinds:
            sts = [s for s in self.state.stimuli if s.kind == kind]
            rts = [s.reaction_time_s for s in sts if s.result == 1]
            out[f"{kind}_n"] = float(len(sts))
            out[f"{kind}_misses"] = float(sum(1 for s in sts if missed(s)))
            out[f"{kind}_mean_rt_s"] = float(np.mean(rts)) if rts else math.nan
        done = [s for s in self.state.stimuli if s.result != 0]
        out["stimuli"] = float(len(self.state.stimuli))
        out["stimulus_misses"] = float(sum(1 for s in self.state.stimuli if missed(s)))
        rts = [s.reaction_time_s for s in done if s.result == 1]
        out["stimulus_mean_rt_s"] = float(np.mean(rts)) if rts else math.nan
        return out
