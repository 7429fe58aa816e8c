"""What a driver model perceives of an env each policy step.

Why: the rule driver and the distracted-driver model must see the same, explicit
snapshot of the world -- lane position, the car ahead, the instruction on a sign, a
light's colour -- so that distraction can be modelled as acting on an *old* snapshot
(a glance away freezes it, a perception delay shifts it). Each env family has a small
reader that fills in its task stimulus; the rest is read from the shared World.

Lateral quantities are in the env's road frame (`sim.guide.RoadGuide`): metres, positive
to the left of travel.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, TypeVar

from ..sim.guide import wrap_angle
from ..sim.perception import lead_vehicle

DEFAULT_CRUISE_MPS = 50.0 / 3.6


@dataclass(frozen=True)
class LeadCar:
    gap_m: float  # bumper to bumper
    speed_mps: float  # along the ego's heading
    brake_light: bool
    turn_signal: int  # 0 off, 1 left, 2 right, 3 both


@dataclass(frozen=True)
class Percept:
    """One snapshot of what the driver knows (see the module docstring for frames)."""

    t_s: float
    speed_mps: float
    lateral_m: float
    heading_error_rad: float
    yaw_rate_radps: float
    target_lateral_m: float  # where the driver means to be across the road
    cruise_mps: float  # the speed the driver means to drive
    lead: LeadCar | None = None
    brake_to_mps: float | None = None  # a brake instruction: get below this speed and hold
    brake_hard: bool = False  # a lead-car brake stimulus (brake light, emergency brake)
    press_reaction: bool = False  # a stimulus answered with the reaction button
    lane_change_pending: bool = False  # the target lane differs from the current one
    sign_distance_m: float | None = None  # to the lane-change sign that set the target (LCT)
    contre: tuple[float, float, float] | None = None  # (target bar m, steering bar m, light 0/1 red/2 green)
    follow_gap_m: float | None = None  # the gap to keep to the lead (platoon band centre)
    engine_off: bool = False  # the engine is not running (a person turns the key first)
    aim: tuple[float, float] | None = None  # on a route: the point to steer at, (ahead, left) m in the car's frame
    curve_speed_mps: float = math.inf  # on a route: the fastest speed that takes the curves ahead
    route_left_m: float = math.inf  # on a route: how far it goes on
    drt_onset_s: float | None = None  # a DRT stimulus is shown: when it came on


Reader = Callable[[Any, Percept], Percept]
T = TypeVar("T")


def evolve(obj: T, **changes: Any) -> T:
    """`dataclasses.replace` for the drivers' frozen dataclasses without `__post_init__`
    (Percept, Intent): the same new object, several times faster (a virtual participant
    makes a few a policy step, a large share of a native-batch study's time)."""
    fields = obj.__dataclass_fields__  # type: ignore[attr-defined]
    if not changes.keys() <= fields.keys():
        raise TypeError(f"{type(obj).__name__} has no field {', '.join(sorted(changes.keys() - fields.keys()))}")
    new = object.__new__(type(obj))
    state = new.__dict__
    state.update(obj.__dict__)
    state.update(changes)
    return new


def _base(env: Any) -> Percept:
    world, guide = env.world, env.guide
    s = world.ego.state
    p = guide.locate(s.x, s.z)
    lane = p.lane_index if p.lane_index >= 0 else guide.nearest_lane(p.lateral_m)
    target = guide.lane_laterals_m[lane]
    engine = world.task.scenario.driver.car.engine
    limit = world.road.current_limit_mps or DEFAULT_CRUISE_MPS
    cruise = min(limit, engine.max_speed_mps)
    if guide.kind == "route":
        lead_car = route_lead(world, guide, p.s_m, target) if world.traffic is not None else None
        aim = _aim(guide, s.x, s.z, s.yaw, s.u, p.s_m, target)
        curve = curve_speed(guide, p.s_m, max(s.u, cruise))
        left = guide.route_length_m() - p.s_m
        if world.traffic is not None and p.s_m < guide.join_s_m:
            left = min(left, merge_stop_left_m(world, guide, p.s_m, s.u))
    else:
        lead = lead_vehicle(world) if world.traffic is not None else None
        if lead is not None and lead.speed_mps < -ONCOMING_MPS:
            lead = None  # coming towards the ego: no lead to follow
        lead_car = LeadCar(lead.gap_m, lead.speed_mps, lead.brake_light, int(world.traffic.turn_signal[lead.index])) if lead else None
        aim, curve, left = None, math.inf, math.inf
    return Percept(
        t_s=world.t_s,
        speed_mps=s.u,
        lateral_m=p.lateral_m,
        heading_error_rad=wrap_angle(s.yaw - p.heading_rad),
        yaw_rate_radps=s.r,
        target_lateral_m=target,
        cruise_mps=cruise,
        lead=lead_car,
        engine_off=not world.ego.powertrain.state.engine_on,
        aim=aim,
        curve_speed_mps=curve,
        route_left_m=left,
    )


LOOKAHEAD_S = 0.9  # pure pursuit: aim this many seconds of travel ahead
LOOKAHEAD_MIN_M = 6.0
CURVE_LATERAL_MPS2 = 3.0  # the lateral acceleration a driver accepts in a curve
CURVE_BRAKE_MPS2 = 2.0  # and the deceleration before one
CURVE_STEP_M = 5.0
LEAD_RANGE_M = 200.0
ONCOMING_MPS = 0.5  # a vehicle closing head-on faster than this is not a lead


def _aim(guide: Any, x: float, z: float, yaw: float, speed: float, s_m: float, lateral_m: float) -> tuple[float, float]:
    """The route point `LOOKAHEAD_S` ahead, shifted to the target lane, in the car's frame."""
    ld = max(LOOKAHEAD_MIN_M, LOOKAHEAD_S * max(speed, 0.0))
    ax, az, ah = guide.polyline.point_at(s_m + ld)
    wx, wz = ax - lateral_m * math.cos(ah), az + lateral_m * math.sin(ah)  # left of heading h is (-cos h, sin h)
    dx, dz = wx - x, wz - z
    return (dx * -math.sin(yaw) + dz * -math.cos(yaw), dx * -math.cos(yaw) + dz * math.sin(yaw))


MERGE_STOP_BEFORE_M = 15.0  # on a connector (a slip road): where to wait before the join
MERGE_GAP_S = 1.5  # a car reaching the join less than this after the ego would: wait (it brakes for the rest)
MERGE_AFTER_S = 1.0  # and one passing the join less than this before the ego would arrive
MERGE_ACCEL_MPS2 = 2.0  # the ego's acceleration towards the join, for its arrival time
MERGE_LANE_HALF_M = 2.5  # a car whose path passes this close to the join point is in its lane
STOP_MARGIN_M = 10.0  # RuleParams.route_end_margin_m: the driver stops this far before `left`


def merge_stop_left_m(world: Any, guide: Any, s_m: float, speed_mps: float) -> float:
    """On the connector from the start pose to the road (a slip road): the route length to
    stop at, before the join, while a traffic car in the joined lane would reach the join
    point within a moment of the ego (gap acceptance); `inf` when the gap is free. A driver checks the
    mirror and yields at a merge; traffic on its path does not brake for the ego in time."""
    if s_m > guide.join_s_m - MERGE_STOP_BEFORE_M:
        return math.inf  # past the waiting point: committed to the join (stopping here would leave the nose in the lane)
    tr = world.traffic
    jx, jz, _ = guide.polyline.point_at(guide.join_s_m)
    d, u = max(guide.join_s_m - s_m, 0.0), max(speed_mps, 0.0)
    ego_eta = (math.sqrt(u * u + 2.0 * MERGE_ACCEL_MPS2 * d) - u) / MERGE_ACCEL_MPS2  # speeding up to it
    for i in range(len(tr.ids)):
        speed = float(tr.speed[i])
        if not tr.enabled[i] or speed < 1.0:
            continue
        x, z, yaw = float(tr.positions[i, 0]), float(tr.positions[i, 2]), float(tr.yaw[i])
        fx, fz = -math.sin(yaw), -math.cos(yaw)  # its heading (yaw 0 faces -z)
        along = (jx - x) * fx + (jz - z) * fz
        across = (jx - x) * fz - (jz - z) * fx
        if along < -5.0 or abs(across) > MERGE_LANE_HALF_M:
            continue  # already past the join point, or its path does not cross it
        if ego_eta - MERGE_AFTER_S < along / speed < ego_eta + MERGE_GAP_S:
            return max(0.0, guide.join_s_m - MERGE_STOP_BEFORE_M - s_m) + STOP_MARGIN_M
    return math.inf


def curve_speed(guide: Any, s_m: float, speed: float) -> float:
    """The fastest speed now from which the driver can slow (at `CURVE_BRAKE_MPS2`) to take
    every curve within the braking distance at `CURVE_LATERAL_MPS2`; curvature is the
    heading change over `2 * CURVE_STEP_M` of route."""
    horizon = speed * speed / (2.0 * CURVE_BRAKE_MPS2) + 4.0 * CURVE_STEP_M
    best = math.inf
    d = 0.0
    h0 = guide.heading_at(s_m - CURVE_STEP_M)
    h1 = guide.heading_at(s_m)
    while d <= horizon:
        h2 = guide.heading_at(s_m + d + CURVE_STEP_M)
        kappa = abs(wrap_angle(h2 - h0)) / (2.0 * CURVE_STEP_M)
        if kappa > 1e-4:
            v = math.sqrt(CURVE_LATERAL_MPS2 / kappa)
            best = min(best, math.sqrt(v * v + 2.0 * CURVE_BRAKE_MPS2 * d))
        h0, h1 = h1, h2
        d += CURVE_STEP_M
    return best


CROSSING_HORIZON_S = 2.5  # a pedestrian who will be in the lane this soon is in the way
CROSSING_MARGIN_M = 1.0


def route_lead(world: Any, guide: Any, s_m: float, lane_lateral_m: float) -> LeadCar | None:
    """The nearest traffic object ahead along the route in the ego's lane (its centre within
    half a lane of the lane centre) that is not coming towards it: an oncoming car in the
    other lane, or one met in a curve, is no lead. A pedestrian counts while it is in the
    lane or will walk into it (with a metre to spare) within `CROSSING_HORIZON_S`."""
    tr = world.traffic
    if tr is None or len(tr.ids) == 0:
        return None
    s = world.ego.state
    fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
    half = guide.lane_width_m / 2.0
    n_cars = len(world.task.scenario.vehicles)  # (traffic rows: vehicles, pedestrians, ODvehicles)
    n_peds = len(world.task.scenario.pedestrians)
    best: tuple[float, int] | None = None
    for i in range(len(tr.ids)):
        if not tr.enabled[i]:
            continue
        x, z = float(tr.positions[i, 0]), float(tr.positions[i, 2])
        dx, dz = x - s.x, z - s.z
        if dx * dx + dz * dz > LEAD_RANGE_M * LEAD_RANGE_M or dx * fx + dz * fz < -5.0 or abs(float(tr.positions[i, 1]) - s.y) > 5.0:
            continue  # far, behind, or parked out of reach below or above the road
        q = guide.polyline.project(x, z)
        ahead = q.s_m - s_m
        if not (0.0 < ahead < LEAD_RANGE_M):
            continue
        heading = guide.heading_at(q.s_m)
        rel = float(tr.yaw[i]) - heading
        speed = float(tr.speed[i])
        off = q.offset_m - lane_lateral_m
        if n_cars <= i < n_cars + n_peds:  # a pedestrian: now or soon in the lane
            later = off + speed * math.sin(rel) * CROSSING_HORIZON_S  # (its velocity across the route: v sin(yaw - heading), + left)
            lo, hi = min(off, later), max(off, later)
            if hi < -half - CROSSING_MARGIN_M or lo > half + CROSSING_MARGIN_M:
                continue
        elif abs(off) > half or (speed > ONCOMING_MPS and math.cos(rel) < 0.0):
            continue  # another lane, or coming towards the ego
        if best is None or ahead < best[0]:
            best = (ahead, i)
    if best is None:
        return None
    ahead, j = best
    gap = ahead - float(tr.half_extents[j, 1]) - 0.5 * world.ego.spec.length_m
    v_along = float(tr.speed[j]) * math.cos(float(tr.yaw[j]) - guide.heading_at(s_m + ahead))
    return LeadCar(gap, v_along, bool(tr.brake_light[j]), int(tr.turn_signal[j]))


def _read_lct(env: Any, p: Percept) -> Percept:
    return _lct_sign(p, env._active_sign(), env.lane_laterals, env.config.speed_kmh, env.world.ego.state.z)


def _lct_sign(p: Percept, sign: Any, lane_laterals: Any, speed_kmh: float, z_m: float) -> Percept:
    """The LCT's stimulus (the last revealed sign) added to `p`: the single env's and a native slot's."""
    speed = speed_kmh / 3.6
    if sign is None:
        return evolve(p, cruise_mps=speed)
    target = lane_laterals[sign.to_lane]
    distance = max(0.0, z_m - sign.z_m)
    pending = abs(target - p.lateral_m) > 1.0
    return evolve(p, target_lateral_m=target, cruise_mps=speed, lane_change_pending=pending, sign_distance_m=distance)


def _read_native_lct(slot: Any) -> Percept:
    """Env `slot.index` of a native LCT batch (`vector.slots.BatchSlot`): the Percept `_base`
    and `_read_lct` give the single env in the same state, read from the batch's arrays
    (`slot.state()`; no traffic, the engine running: what `vector.slots` admits)."""
    t, x, z, yaw, u, r, revealed = slot.state()
    b = slot.batch
    guide, tpl = b.guide, b.template
    q = guide.locate(x, z)
    lane = q.lane_index if q.lane_index >= 0 else guide.nearest_lane(q.lateral_m)
    engine = tpl.world.task.scenario.driver.car.engine
    p = Percept(
        t_s=t,
        speed_mps=u,
        lateral_m=q.lateral_m,
        heading_error_rad=wrap_angle(yaw - q.heading_rad),
        yaw_rate_radps=r,
        target_lateral_m=guide.lane_laterals_m[lane],
        cruise_mps=min(tpl.world.road.current_limit_mps or DEFAULT_CRUISE_MPS, engine.max_speed_mps),
    )
    return _lct_sign(p, tpl.sign_specs[revealed] if revealed >= 0 else None, tpl.lane_laterals, tpl.config.speed_kmh, z)


def _read_reaction_test(env: Any, p: Percept) -> Percept:
    engine = env.world.task.scenario.driver.car.engine
    start = env.world.task.start_pose.position_m
    home = env.guide.lane_laterals_m[env.guide.nearest_lane(env.guide.locate(start[0], start[2]).lateral_m)]
    p = replace(p, cruise_mps=engine.max_speed_mps, target_lateral_m=home)  # trials start in the centre lane
    sign = env._active_sign()
    if sign is None and any(t.kind == "laneChange" and t.armed for t in env.world.triggers.center.timers.values()):
        # a lane change is scored after 2 s in the lane: hold the last passed sign's lane until then
        z = env.world.ego.state.z
        passed = [s for s in env.signs if s.kind == 2.0 and s.z_m >= z]
        sign = min(passed, key=lambda s: s.z_m) if passed else None
    if sign is None:
        return p
    if sign.kind == 2.0:
        target = env.guide.lane_laterals_m[sign.lane]
        return replace(p, target_lateral_m=target, lane_change_pending=True)
    timer = next((t for t in env.world.triggers.center.timers.values() if t.kind == "brake"), None)
    target_mps = timer.target_speed_mps if timer is not None else 40.0 / 3.6
    return replace(p, brake_to_mps=target_mps) if timer is not None else p


def _read_platoon(env: Any, p: Percept) -> Percept:
    spec = env.platoon.spec
    band = spec.longitudinal_tolerance
    follow = 0.5 * (band.lower_bound_m + band.upper_bound_m) if band is not None else 27.5
    active = env.platoon.state.active
    kinds = {st.kind for st in active if st.result == 0}
    brake = bool(kinds & {"brakeLight", "emergencyBrake"})
    press = any(k.endswith("TurnSignal") for k in kinds)
    slow = next((st.target_mps for st in active if st.kind == "speedReduction" and st.result == 0), None)
    cruise = env.config.speed_kmh / 3.6
    p = replace(p, cruise_mps=cruise, follow_gap_m=follow, brake_hard=brake, press_reaction=press)
    if slow is not None:
        p = replace(p, brake_to_mps=slow)
    timer = next((t for t in env.world.triggers.center.timers.values() if t.kind == "brake" and t.armed), None)
    if timer is not None:
        p = replace(p, brake_to_mps=timer.target_speed_mps)
    return p


def _read_contre(env: Any, p: Percept) -> Percept:
    return replace(p, contre=(env.target_l, env.steer_l, env.light))


def _readers() -> list[tuple[type, Reader]]:
    """Most specific env class first (the brake test is a platoon env)."""
    from ..envs.contre import ConTReEnv
    from ..envs.lct import LaneChangeTestEnv
    from ..envs.platoon import ThreeVehiclePlatoonEnv
    from ..envs.reaction_test import ReactionTestEnv

    return [
        (LaneChangeTestEnv, _read_lct),
        (ReactionTestEnv, _read_reaction_test),
        (ThreeVehiclePlatoonEnv, _read_platoon),
        (ConTReEnv, _read_contre),
    ]


def perceive(env: Any, info: dict[str, Any] | None = None) -> Percept:
    """The driver's snapshot of `env` (a gymnasium env or wrapper) now."""
    base = env.unwrapped
    if getattr(base, "native_slot", False):  # one env of a native batch (`vector.slots`)
        p = _read_native_lct(base)
    else:
        p = _base(base)
        for cls, reader in _readers():
            if isinstance(base, cls):
                p = reader(base, p)
                break
    if info and float(info.get("drt_stimulus_on", 0.0)) > 0.0:
        drt = find_drt(env)
        onsets = getattr(drt, "onsets", None)
        p = replace(p, press_reaction=True, drt_onset_s=float(onsets[-1]) if onsets else None)
    return p


def find_drt(env: Any) -> Any:
    """The Detection Response Task wrapper around `env`, or None (walks `.env`)."""
    from ..envs.drt import DetectionResponseTask

    e = env
    while e is not None:
        if isinstance(e, DetectionResponseTask):
            return e
        e = getattr(e, "env", None)
    return None
