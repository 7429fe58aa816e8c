"""Per-step traffic maths over all objects at once: follow box, obstacles, speed, steering.

Why: issue 9 wants dozens of cars at many times real time, so every per-step rule of
OpenDS's `FollowBox` and `TrafficCar` is written here as numpy array operations over all
objects; per-object Python runs only on rare events (a leg ends, a light is passed).

The rules (OPENDS.md section 1b):
* the follow box ("carrot") runs along the path at (path speed + 10 km/h) scaled by
  1 - (d - minDist)/(maxDist - minDist), d = car-carrot distance clamped to the range, so
  it waits for its car (it also runs at least as fast as the car, so a car told to go
  faster than its path never overtakes its own carrot);
* steering toward the carrot = sign * min(1, 4 * angle / pi) of the wheel lock;
* target speed: the leg's speed, lowered ahead of a slower next leg so that the car slows
  at 50 % of its brake deceleration; 0 for an obstacle (the ego car, other traffic) with
  lateral < minLateralSafetyDistance and 0 < forward < max(minForward, 0.5 v[km/h]),
  checked along the car's heading and toward its next waypoint, and 0 for a red light on
  the next lighted waypoint once it is that close; in a turn tighter than the path speed
  allows (see `bend_speed`) the car slows down;
* below target: accelerate at `acceleration`; more than 1 km/h above: brake
  (v - target - 1)/2 (km/h) of `decelerationBrake`, plus OpenDS's constant friction of
  0.2 x `decelerationFreeWheel` (without it a car told to stop creeps on at 1 km/h);
  otherwise free-wheel at `decelerationFreeWheel`. Cars move as kinematic bicycles.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .vehicle import MAX_WHEEL_ANGLE_RAD

CARROT_LEAD_MPS = 10.0 / 3.6
WHEELBASE_M = 2.7
BEND_ACCEL_MPS2 = 4.0  # lateral acceleration a car accepts when its carrot asks for a tight turn
BEND_MIN_ANGLE_RAD = 0.25 * np.pi  # ... that is, when the carrot lies more than 45 degrees off its heading
FRICTION_SHARE = 0.2  # OpenDS always applies 0.2 x the free-wheel force as friction


@dataclass
class MotionState:
    """Everything about the objects that changes during a run (numpy arrays, one row each)."""

    pos: np.ndarray  # (N,3) world metres
    yaw: np.ndarray
    speed: np.ndarray
    enabled: np.ndarray
    engine_on: np.ndarray
    pid: np.ndarray  # current path id (-1: no route)
    s: np.ndarray  # carrot arc length on that path
    leg: np.ndarray  # Gen A: leg index; Gen B: segment index
    next_seg: np.ndarray  # Gen B: segment after this one (-1 end point)
    leg_end: np.ndarray  # arc length where the current leg ends
    v_leg: np.ndarray
    v_next: np.ndarray
    end_xz: np.ndarray  # (N,2) position of the leg's end waypoint
    wait_until: np.ndarray  # NaN unless waiting at a waypoint
    waited: np.ndarray  # the wait at the current leg end is over
    halted: np.ndarray  # at an end point for good
    light_idx: np.ndarray  # next lighted waypoint's light (-1 none)
    light_xz: np.ndarray
    turn_path: np.ndarray
    brake_path: np.ndarray  # -1 not set by the path, 0 off, 1 on
    head_light: np.ndarray
    braking: np.ndarray
    blocked: np.ndarray  # an obstacle within the safety distance
    ov_speed: np.ndarray  # NaN: no override
    ov_decel: np.ndarray
    ov_brake: np.ndarray  # -1 none
    ov_turn: np.ndarray  # -1 none
    ext: np.ndarray
    ext_cmd: np.ndarray  # (N,3) steering, accelerator, brake
    min_fwd: np.ndarray
    lat_safe: np.ndarray
    speed_dep: np.ndarray
    stuck_hist: np.ndarray  # (N,7,2) positions once a second
    stuck_n: np.ndarray
    lane_hold_until: np.ndarray  # a requested lane change suspends automatic lane choice until then

    @staticmethod
    def empty(n: int) -> MotionState:
        f = lambda v=0.0: np.full(n, v, dtype=float)  # noqa: E731
        i = lambda v=-1: np.full(n, v, dtype=np.int64)  # noqa: E731
        b = lambda v=False: np.full(n, v, dtype=bool)  # noqa: E731
        return MotionState(
            pos=np.zeros((n, 3)), yaw=f(), speed=f(), enabled=b(True), engine_on=b(True), pid=i(), s=f(), leg=i(0),
            next_seg=i(), leg_end=f(), v_leg=f(), v_next=f(), end_xz=np.zeros((n, 2)), wait_until=f(np.nan), waited=b(),
            halted=b(), light_idx=i(), light_xz=np.zeros((n, 2)), turn_path=i(0), brake_path=i(), head_light=f(), braking=b(),
            blocked=b(), ov_speed=f(np.nan), ov_decel=f(np.nan), ov_brake=i(), ov_turn=i(), ext=b(), ext_cmd=np.zeros((n, 3)),
            min_fwd=f(8.0), lat_safe=f(2.0), speed_dep=b(True), stuck_hist=np.zeros((n, 7, 2)), stuck_n=i(0), lane_hold_until=f(-1.0),
        )  # fmt: skip

    def copy(self) -> MotionState:
        return MotionState(**{f.name: getattr(self, f.name).copy() for f in fields(self)})


@dataclass(frozen=True)
class Specs:
    """Fixed per-object parameters (from the task), one row each; the `_`-fields are derived
    once here so the per-step functions do not recompute them."""

    is_car: np.ndarray
    accel: np.ndarray
    dec_brake: np.ndarray
    dec_free: np.ndarray
    min_dist: np.ndarray
    max_dist: np.ndarray
    max_speed: np.ndarray
    never_faster: np.ndarray
    _span_ok: np.ndarray = field(init=False, repr=False, compare=False)
    _span_safe: np.ndarray = field(init=False, repr=False, compare=False)
    _friction: np.ndarray = field(init=False, repr=False, compare=False)
    _any_never_faster: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        span = self.max_dist - self.min_dist
        ok = span > 1e-6
        derived = {
            "_span_ok": ok,
            "_span_safe": np.where(ok, span, 1.0),
            "_friction": FRICTION_SHARE * self.dec_free,
            "_any_never_faster": bool(np.any(self.never_faster)),
        }
        for name, value in derived.items():
            object.__setattr__(self, name, value)  # (a frozen dataclass's derived fields)


def carrot_speed(st: MotionState, sp: Specs, d: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """How fast each carrot moves along its path this step (pedestrians: their own speed).

    A carrot beside or behind its car (the car overshot a hairpin) runs on at full speed:
    a waiting carrot there would have the car circle it forever.
    """
    dc = np.minimum(np.maximum(d, sp.min_dist), sp.max_dist)  # (np.clip is several times slower)
    factor = np.where(sp._span_ok, 1.0 - (dc - sp.min_dist) / sp._span_safe, (d < sp.max_dist).astype(float))
    factor = np.where(np.abs(ang) >= 0.5 * np.pi, 1.0, factor)
    return np.where(sp.is_car, (np.maximum(st.v_leg, st.speed) + CARROT_LEAD_MPS) * factor, np.minimum(st.v_leg, sp.max_speed))


def forward_safety_m(st: MotionState) -> np.ndarray:
    """OpenDS's forward safety distance: max(minForward, 0.5 x speed in km/h) (minForward alone
    when the speed-dependent rule is off)."""
    return np.maximum(st.min_fwd, np.where(st.speed_dep, 1.8 * st.speed, 0.0))


def obstacles(
    st: MotionState,
    rows: np.ndarray,
    ego_xz: tuple[float, float],
    fsafe: np.ndarray | None = None,
    sin_yaw: np.ndarray | None = None,
    cos_yaw: np.ndarray | None = None,
) -> np.ndarray:
    """Which objects (of `rows`) have an obstacle (traffic, the ego car) within their safety distance.

    Only pairs closer than the reach of the safety box are examined, so the cost grows with
    the number of close pairs; the N x (N+1) distance test is the only quadratic part.
    `fsafe` (`forward_safety_m`) and np.sin/np.cos of `st.yaw` may be passed when known.
    """
    n = len(st.speed)
    out = np.zeros(n, dtype=bool)
    idx = np.flatnonzero(rows)
    if idx.size == 0:
        return out
    ox, oz = np.empty(n + 1), np.empty(n + 1)  # every object, then the ego car
    ox[:n], oz[:n] = st.pos[:, 0], st.pos[:, 2]
    ox[n], oz[n] = ego_xz
    if fsafe is None:
        fsafe = forward_safety_m(st)
    reach = fsafe[idx] + st.lat_safe[idx]
    rx, rz = ox - ox[idx, None], oz - oz[idx, None]
    near = rx * rx + rz * rz < (reach * reach)[:, None]
    near[:, :n] &= st.enabled
    near[np.arange(idx.size), idx] = False
    a, b = near.nonzero()
    if a.size == 0:
        return out
    rxa, rza, i = rx[a, b], rz[a, b], idx[a]
    if sin_yaw is None or cos_yaw is None:
        fx, fz = -np.sin(st.yaw[i]), -np.cos(st.yaw[i])
    else:
        fx, fz = -sin_yaw[i], -cos_yaw[i]
    ux, uz = st.end_xz[i, 0] - ox[i], st.end_xz[i, 1] - oz[i]
    un = np.hypot(ux, uz)
    ok = un > 1e-6
    inv = np.divide(1.0, un, out=np.zeros_like(un), where=ok)
    ux, uz = np.where(ok, ux * inv, fx), np.where(ok, uz * inv, fz)
    lat_safe, fs = st.lat_safe[i], fsafe[i]
    f1, f2 = rxa * fx + rza * fz, rxa * ux + rza * uz  # along the heading, and toward the next waypoint
    hit = (np.abs(rxa * fz - rza * fx) < lat_safe) & (f1 > 0.0) & (f1 < fs)
    hit |= (np.abs(rxa * uz - rza * ux) < lat_safe) & (f2 > 0.0) & (f2 < fs)
    near[a, b] = hit
    # two cars that wait for each other (crossing paths) would wait forever: the one listed
    # first goes (OpenDS has no such rule; its stuck cars were reset by `resetWhenStuck`)
    row_of = np.full(n + 1, -1)
    row_of[idx] = np.arange(idx.size)
    ha, hb = a[hit], b[hit]
    rb = row_of[hb]
    mutual = (rb >= 0) & (idx[ha] < hb)
    mutual[mutual] = near[rb[mutual], idx[ha[mutual]]]
    out[idx[ha[~mutual]]] = True
    return out


def target_speed(st: MotionState, sp: Specs, d: np.ndarray, ego_speed: float, waiting: np.ndarray | None = None) -> np.ndarray:
    """The path's wish (leg speed, anticipation of a slower next leg, caps and overrides).

    `waiting` (optional) is `~np.isnan(st.wait_until)`, when the caller has it already.
    """
    vt = np.minimum(st.v_leg, sp.max_speed)
    dist_end = np.maximum(0.0, st.leg_end - (st.s - d))  # from the car (about d behind its carrot)
    v_allow = np.sqrt(st.v_next**2 + sp.dec_brake * dist_end)  # v^2 + 2 (0.5 decelerationBrake) dist
    vt = np.where(st.v_next < vt, np.minimum(vt, v_allow), vt)
    if sp._any_never_faster:
        vt = np.where(sp.never_faster, np.minimum(vt, max(0.0, ego_speed)), vt)
    vt = np.where(np.isnan(st.ov_speed), vt, st.ov_speed)
    if waiting is None:
        waiting = ~np.isnan(st.wait_until)
    return np.where(st.halted | waiting, 0.0, vt)


def longitudinal(st: MotionState, sp: Specs, vt: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(new speed, braking) from OpenDS's pedal rule, overrides and external control.

    The override and external-control terms are evaluated only when some object has one
    (they leave every other row as it is).
    """
    v = st.speed
    vk, tk = 3.6 * v, 3.6 * vt
    below = v < vt
    above = vk > tk + 1.0
    brake = np.minimum(np.maximum((vk - tk - 1.0) / 2.0, 0.0), 1.0)
    friction = sp._friction
    gas = np.where(st.engine_on, np.minimum(sp.accel, (vt - v) / dt), -friction)
    a = np.where(below, gas, np.where(above, -brake * sp.dec_brake - friction, -sp.dec_free))
    decel_set = np.isfinite(st.ov_decel)
    forced = decel_set & (v > vt) if decel_set.any() else None
    if forced is not None:
        a = np.where(forced, -st.ov_decel, a)
    ext = st.ext if st.ext.any() else None
    if ext is not None:
        acc_cmd, brake_cmd = st.ext_cmd[:, 1], st.ext_cmd[:, 2]
        a_ext = np.where(st.engine_on, acc_cmd * sp.accel, 0.0) - brake_cmd * sp.dec_brake - friction
        a = np.where(ext, a_ext, a)
    v_new = np.maximum(0.0, v + a * dt)
    if forced is not None:
        v_new = np.where(forced & ~st.ext, np.maximum(v_new, vt), v_new)
    braking = above & ~below
    if forced is not None:
        braking |= forced
    if ext is not None:
        braking = np.where(ext, st.ext_cmd[:, 2] > 0.0, braking)
    return v_new, braking


def carrot_angle(
    st: MotionState, cx: np.ndarray, cz: np.ndarray, sin_yaw: np.ndarray | None = None, cos_yaw: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(angle to the carrot, positive to the left; distance to it) for every object.

    `sin_yaw`/`cos_yaw` (optional) are np.sin/np.cos of `st.yaw`, when the caller has them.
    """
    if sin_yaw is None or cos_yaw is None:
        sin_yaw, cos_yaw = np.sin(st.yaw), np.cos(st.yaw)
    dx, dz = cx - st.pos[:, 0], cz - st.pos[:, 2]
    ndx = -dx
    ahead = ndx * sin_yaw - dz * cos_yaw
    side = ndx * cos_yaw + dz * sin_yaw
    return np.arctan2(side, ahead), np.hypot(dx, dz)


def bend_speed(ang: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Speed at which the arc to the carrot stays within BEND_ACCEL_MPS2 of lateral acceleration.

    OpenDS's physical cars lose speed in turns they cannot make; a kinematic car would
    swing wide (or circle its carrot), so once the carrot lies more than 45 degrees off the
    heading (hairpins, overshot corners) it slows down: radius d / (2 sin(angle)), and the
    tightest one (d/2) when the carrot is beside or behind the car. Ordinary tracking, with
    small angles, is never slowed.
    """
    abs_ang = np.abs(ang)
    bend = abs_ang > BEND_MIN_ANGLE_RAD
    if not bend.any():  # the usual step: every carrot close to straight ahead
        return np.full(len(ang), np.inf)
    s = np.where(abs_ang < 0.5 * np.pi, np.abs(np.sin(ang)), 1.0)
    radius = 0.5 * d / np.maximum(s, 1e-9)
    v = np.sqrt(BEND_ACCEL_MPS2 * np.maximum(radius, 0.5 * WHEELBASE_M))
    return np.where(bend, v, np.inf)


def steer_and_move(st: MotionState, rows: np.ndarray, ang: np.ndarray, v_new: np.ndarray, dt: float) -> None:
    """Steer toward the carrot (`ang` from `carrot_angle`) or as commanded; integrate the bicycle."""
    yaw = st.yaw
    steer = np.sign(ang) * np.minimum(1.0, 4.0 * np.abs(ang) / np.pi)
    if st.ext.any():
        steer = np.where(st.ext, st.ext_cmd[:, 0], steer)  # (set_external_control keeps it in [-1, 1])
    new_yaw = yaw + v_new / WHEELBASE_M * np.tan(steer * MAX_WHEEL_ANGLE_RAD) * dt
    new_yaw = (new_yaw + np.pi) % (2.0 * np.pi) - np.pi
    st.yaw = np.where(rows, new_yaw, yaw)
    px, pz = st.pos[:, 0], st.pos[:, 2]
    st.pos[:, 0] = np.where(rows, px - v_new * np.sin(st.yaw) * dt, px)
    st.pos[:, 2] = np.where(rows, pz - v_new * np.cos(st.yaw) * dt, pz)
    st.speed = np.where(rows, v_new, st.speed)
