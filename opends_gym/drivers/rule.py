"""A competent rule-based driver that works on every registered env.

Why: researchers need a reference driver to compare human and learned drivers with,
scored by the same metrics. It keeps its lane with Stanley's lateral law, changes lanes
along a constant-gradient path when a sign says so (the shape of the LCT's basic
normative model), holds its speed, follows a lead car with the Intelligent Driver Model
(Treiber, Hennecke & Helbing 2000) or, in the platoon task, at the centre of the
tolerance band, brakes for brake stimuli and brake signs, and presses the reaction
button for turn-signal and DRT stimuli.

It decides from a `Percept` (see `percept.py`), so the distracted-driver model can feed
it stale or delayed percepts without knowing anything about the tasks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym

from ..control.controllers import pure_pursuit, stanley_steering
from .intent import Intent, to_action
from .pedal_map import PedalMap, pedal_map
from .percept import Percept, perceive


@dataclass(frozen=True)
class RuleParams:
    """Driving style. Units in the names; defaults describe an attentive, brisk driver."""

    lane_change_m_per_lane: float = 40.0  # travel per lane width while changing lanes (LCT basic model: 40 m)
    lane_change_start_before_sign_m: float = 30.0  # LCT: start moving this far before the sign (basic model: 30 m)
    reaction_lane_change_m_per_lane: float = 20.0  # reaction tasks (no LCT sign distance): a swift change
    lane_width_m: float = 3.75
    brake_margin_mps: float = 3.0 / 3.6  # drive this much below a brake target
    stimulus_brake: float = 0.35  # pedal while a lead-car brake stimulus lasts
    throttle_kp: float = 0.25  # pedal per m/s below the set-point
    brake_kp: float = 0.1  # brake per m/s above it
    speed_ki: float = 0.08  # integral gain, pedal per (m/s * s)
    speed_integral_limit: float = 0.6
    speed_integral_band_mps: float = 3.0
    speed_deadband_mps: float = 0.1
    idm_time_gap_s: float = 1.5
    idm_min_gap_m: float = 2.0
    idm_accel_mps2: float = 1.5
    idm_comfort_decel_mps2: float = 2.0
    idm_horizon_s: float = 1.0  # the IDM's acceleration becomes a speed set-point this far ahead
    band_gap_gain_per_s: float = 0.3  # platoon: m/s faster than the lead per metre of gap beyond the band centre
    platoon_overspeed_mps: float = 15.0 / 3.6  # platoon: may exceed the cruise speed this much to close a gap
    contre_response_s: float = 0.25  # ConTRe: time to close the bar gap
    contre_bar_speed_mps: float = 1.0
    route_end_margin_m: float = 10.0  # stop this far before the end of the known route
    drt_min_rt_s: float = 0.1  # ISO 17488 counts a DRT response sooner than 100 ms as premature: wait this long


@dataclass
class _Plan:
    lateral_m: float | None = None  # the lane-change path's current lateral position
    t_s: float | None = None


def start_engine(env: Any, p: Percept) -> None:
    """A person turns the ignition key when the engine is off (the task's `<engineOn>` is
    false): `OpenDSEnv.turn_engine_key`, whatever the env's action type carries."""
    if p.engine_off:
        turn = getattr(env.unwrapped, "turn_engine_key", None)
        if turn is not None:
            turn(True)


class RuleDriver:
    """Agent interface of `opends_gym.drivers.agents`: `reset(env, seed)`, `act(obs, info)`."""

    name = "rule"

    def __init__(self, params: RuleParams | None = None) -> None:
        self.params = params or RuleParams()
        self.env: Any = None
        self._plan = _Plan()
        self._integral = 0.0
        self._pedal_t: float | None = None

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        self.env = env
        self._plan = _Plan()
        self._integral = 0.0
        self._pedal_t = None
        base: Any = env.unwrapped
        so = getattr(getattr(base, "contre", None), "steering_object", None)
        self._bar_speed = float(so.speed) if so is not None and so.speed > 0 else self.params.contre_bar_speed_mps
        self._wheelbase = float(base.world.ego.spec.wheelbase_m)
        self.pedals: PedalMap = pedal_map(base.world.ego.car, float(base.world.ego.spec.mass_kg))

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        p = perceive(self.env, info)
        start_engine(self.env, p)
        return to_action(self.env, self.decide(p))

    # ------------------------------------------------------------------ decisions
    def decide(self, p: Percept) -> Intent:
        """What to do given a percept (pure apart from the lane-change plan)."""
        if p.contre is not None:
            return self._contre(p)
        steer = self._steer(p)
        pedal = self._pedal(p)
        return Intent(
            steering=steer,
            pedal=pedal,
            reaction=self._press(p),
            target_lateral_m=p.target_lateral_m,
            target_speed_mps=p.brake_to_mps if p.brake_to_mps is not None else p.cruise_mps,
        )

    def _press(self, p: Percept) -> bool:
        """Hold the reaction button for a stimulus; a DRT stimulus only once the press (on
        the next physics step) lands `drt_min_rt_s` or more after its onset."""
        if not p.press_reaction:
            return False
        return p.drt_onset_s is None or p.t_s - p.drt_onset_s >= self.params.drt_min_rt_s

    def _steer(self, p: Percept) -> float:
        """Stanley onto a path that ramps to the target lateral at the lane-change gradient;
        on a route (curves, turns) pure pursuit of its point ahead in the target lane."""
        prm = self.params
        if p.aim is not None:
            ahead, left = p.aim
            return pure_pursuit(ahead, left, self._wheelbase)
        plan = self._plan
        per_lane = prm.lane_change_m_per_lane if p.sign_distance_m is not None else prm.reaction_lane_change_m_per_lane
        slope = prm.lane_width_m / per_lane
        if plan.lateral_m is None or plan.t_s is None or p.t_s < plan.t_s:
            plan.lateral_m, plan.t_s = p.lateral_m if p.lane_change_pending else p.target_lateral_m, p.t_s
        ds = max(0.0, p.speed_mps) * (p.t_s - plan.t_s)
        plan.t_s = p.t_s
        target = p.target_lateral_m
        if p.sign_distance_m is not None and p.sign_distance_m > prm.lane_change_start_before_sign_m:
            target = plan.lateral_m  # sign seen; the move starts at the planned point
        gap = target - plan.lateral_m
        step = slope * ds
        plan.lateral_m = target if abs(gap) <= step else plan.lateral_m + math.copysign(step, gap)
        moving = abs(target - plan.lateral_m) > 1e-6
        path_heading = math.copysign(math.atan(slope), gap) if moving else 0.0
        return stanley_steering(p.heading_error_rad, path_heading, p.lateral_m, plan.lateral_m, p.speed_mps, p.yaw_rate_radps)

    def _pedal(self, p: Percept) -> float:
        """A speed set-point (cruise, brake target, lead car) held by a PI controller on top
        of the car's hold throttle (`pedal_map`: the accelerator that beats drag at this
        speed). A negative output asks for a deceleration (brake-pedal units): up to the
        car's coasting deceleration the foot eases the accelerator and stays on it; beyond
        that it brakes for the rest. So a driver following a steady lead holds the
        accelerator, as drivers do."""
        prm = self.params
        err = self._speed_setpoint(p) - p.speed_mps
        dt = 0.0 if self._pedal_t is None else min(max(p.t_s - self._pedal_t, 0.0), 0.5)
        self._pedal_t = p.t_s
        band = prm.speed_integral_band_mps
        if abs(err) < band:  # integrate near the set-point only (no wind-up)
            self._integral = max(-prm.speed_integral_limit, min(prm.speed_integral_limit, self._integral + prm.speed_ki * err * dt))
        elif err < -band:  # far too fast: no throttle left over from cruising
            self._integral = min(self._integral, 0.0)
        else:
            self._integral = max(self._integral, 0.0)
        if abs(err) < prm.speed_deadband_mps:
            err = 0.0
        u = self._integral + (prm.throttle_kp * err if err >= 0.0 else prm.brake_kp * err)
        pm = self.pedals
        hold = pm.hold_throttle(p.speed_mps)
        if u >= 0.0:
            pedal = hold + u
        else:
            need = -u * pm.brake_mps2  # the deceleration asked for, m/s^2
            coast = pm.coast_decel(p.speed_mps)
            pedal = pm.throttle_for(p.speed_mps, -need) if need < coast else -(need - coast) / pm.brake_mps2
        if p.brake_hard:
            pedal = min(pedal, -prm.stimulus_brake)
        return max(-1.0, min(1.0, pedal))

    def _speed_setpoint(self, p: Percept) -> float:
        prm = self.params
        target = min(p.cruise_mps, p.curve_speed_mps)
        if p.route_left_m < math.inf:  # stop where the known road ends
            target = min(target, math.sqrt(2.0 * prm.idm_comfort_decel_mps2 * max(0.0, p.route_left_m - prm.route_end_margin_m)))
        if p.brake_to_mps is not None:
            target = min(target, p.brake_to_mps - prm.brake_margin_mps)
        lead = p.lead
        if lead is None:
            return target
        if p.follow_gap_m is not None and p.brake_to_mps is None:
            # platoon: the gap to the lead sets the pace, up to a little over the cruise speed
            v = lead.speed_mps + prm.band_gap_gain_per_s * (lead.gap_m - p.follow_gap_m)
            return max(0.0, min(v, target + prm.platoon_overspeed_mps))
        return max(0.0, min(target, p.speed_mps + prm.idm_horizon_s * self._idm(p, target)))

    def _idm(self, p: Percept, v0: float) -> float:
        """The Intelligent Driver Model's acceleration behind the lead."""
        prm = self.params
        lead = p.lead
        assert lead is not None
        dv = p.speed_mps - lead.speed_mps
        v = max(p.speed_mps, 0.0)
        s_star = prm.idm_min_gap_m + v * prm.idm_time_gap_s + v * dv / (2.0 * math.sqrt(prm.idm_accel_mps2 * prm.idm_comfort_decel_mps2))
        gap = max(lead.gap_m, 0.1)
        free = 1.0 - (v / max(v0, 0.1)) ** 4
        return prm.idm_accel_mps2 * (free - (max(s_star, 0.0) / gap) ** 2)

    def _contre(self, p: Percept) -> Intent:
        assert p.contre is not None
        target, bar, light = p.contre
        steer = (target - bar) / (self._bar_speed * self.params.contre_response_s)
        pedal = -1.0 if light == 1.0 else 1.0 if light == 2.0 else 0.0
        return Intent(steering=max(-1.0, min(1.0, steer)), pedal=pedal, target_lateral_m=p.target_lateral_m, target_speed_mps=p.cruise_mps)
