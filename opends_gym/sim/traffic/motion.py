"""Per-step traffic maths as compiled kernels: follow box, obstacles, speed, steering.

Why: issue 9 wants dozens of cars at many times real time, and the brake and platoon tests
(one or two cars) paid ~270 us per step in fixed numpy overhead. So every per-step rule of
OpenDS's `FollowBox` and `TrafficCar` is a loop over the objects here, compiled with numba
(`jit`); per-object Python runs only on rare events (a wait ends, a leg ends, a light
is passed), between the two kernels of a step. The native batch calls the same kernels on
the cars of all its envs (`group` objects per world), so its traffic is the single env's.

The rules (OpenDS `TrafficCar`, `FollowBox`; docs/opends-compatibility.md#traffic):
* the follow box ("carrot") runs along the path at (path speed + 10 km/h) scaled by
  1 - (d - minDist)/(maxDist - minDist), d = car-carrot distance clamped to the range, so
  it waits for its car (it also runs at least as fast as the car, so a car told to go
  faster than its path never overtakes its own carrot); a carrot beside or behind its car
  runs on at full speed (a waiting carrot there would have the car circle it forever);
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
* two cars that wait for each other (crossing paths) would wait forever: the one listed
  first goes (OpenDS has no such rule; its stuck cars were reset by `resetWhenStuck`).

Units: metres, seconds, m/s, rad (yaw 0 faces -Z, positive turns left).
"""

from __future__ import annotations

import math

import numpy as np

from ...jit import borrowing_kernel, inline, kernel
from ..ego.spec import MAX_WHEEL_ANGLE_RAD
from . import state as ts
from .paths import PF_DX, PF_DY, PF_DZ, PF_LEN, PF_OK, PF_S, PF_X, PF_Y, PF_YAW, PF_Z, PI_FIRST, PI_LAST_PIECE, PP_LEN, PP_OFF, piece_at
from .state import MotionState, Specs

__all__ = ["MotionState", "Specs", "advance_carrots", "bend_speed", "continue_on_network", "drive", "outputs"]

CARROT_LEAD_MPS = 10.0 / 3.6
WHEELBASE_M = 2.7
BEND_ACCEL_MPS2 = 4.0  # lateral acceleration a car accepts when its carrot asks for a tight turn
BEND_MIN_ANGLE_RAD = 0.25 * math.pi  # ... that is, when the carrot lies more than 45 degrees off its heading
# rows of the per-step scratch array `work` (one column per object)
W_CX, W_CY, W_CZ, W_CYAW, W_ANG, W_D, W_CV, W_VT, W_FSAFE, W_FX, W_FZ, W_UX, W_UZ, W_HINT, W_KEY = range(15)
# ... and rows kept from step to step that only save work (results never depend on them): sin
# and cos of the yaw W_TRIG_YAW (valid where W_TRIG_OK is 1; a yaw of zero is always taken
# afresh, its sign unchecked), and each world's objects in order along its sorted axis (object
# indices, as floats; W_RANK: the inverse, rebuilt every step)
W_SIN, W_COS, W_TRIG_YAW, W_TRIG_OK, W_ORDER, W_RANK = range(15, 21)
N_WORK = 21
TWO_PI = 2.0 * math.pi
# bits of `flags` (one per object): what Python must handle between and after the kernels
WAIT_OVER, ARRIVED, MOVING, PASSED_LIGHT, BLOCK, LIVE, CAR = 1, 2, 4, 8, 16, 32, 64
NOTHING_LIVE, WAITS_OVER = -2, -1
SORT_ABOVE = 8  # worlds with more objects look for obstacles along a sorted axis

# The helpers below take and return numbers only: a compiled call that passes an array
# updates its reference count, which costs more than these few operations. The loops over
# the objects (and all array reads and writes) are in the kernels.


@inline
def _dist(dx: float, dz: float) -> float:
    """Length of (dx, dz): sqrt of the sum of squares (IEEE-exact operations, so compiled and
    plain-Python runs agree; hypot's extra care is not needed at road scale)."""
    return math.sqrt(dx * dx + dz * dz)


@inline
def sin_cos(a: float) -> tuple[float, float]:
    """`math.sin(a), math.cos(a)`, at a = +-0 their exact values (+-0, 1) without the calls:
    the same floats (C99 Annex F), and the cars of a straight road keep their yaw at 0 (the
    brake and platoon tests' cars always), where the kept sine and cosine (`W_TRIG_OK`)
    cannot be used (0.0 == -0.0: the sign is not checked there)."""
    if a == 0.0:
        return a, 1.0
    return math.sin(a), math.cos(a)


@inline
def _aim(cx: float, cz: float, x: float, z: float, sin_yaw: float, cos_yaw: float) -> tuple[float, float]:
    """(angle to the carrot at (cx, cz), positive to the left; distance to it) from (x, z),
    heading with sine and cosine sin_yaw, cos_yaw."""
    dx, dz = cx - x, cz - z
    ndx = -dx
    ahead = ndx * sin_yaw - dz * cos_yaw
    side = ndx * cos_yaw + dz * sin_yaw
    # (atan2(+-0, x > 0) is +-0 exactly (C99 Annex F): a car on a straight path has its carrot dead ahead)
    return (side if side == 0.0 and ahead > 0.0 else math.atan2(side, ahead)), _dist(dx, dz)


@inline
def _carrot_speed(d: float, ang: float, lo: float, hi: float, span_ok: bool, span: float, is_car: bool, v: float, v_leg: float,
                  cap: float) -> float:  # fmt: skip
    """How fast the carrot moves along its path this step (pedestrians: their own speed)."""
    dc = d if d > lo else lo
    dc = dc if dc < hi else hi
    factor = 1.0 - (dc - lo) / span if span_ok else (1.0 if d < hi else 0.0)
    if abs(ang) >= 0.5 * math.pi:
        factor = 1.0
    if is_car:
        return ((v if v > v_leg else v_leg) + CARROT_LEAD_MPS) * factor
    return cap if cap < v_leg else v_leg


@inline
def _target_speed(v_leg: float, cap: float, to_end: float, v_next: float, dec_brake: float, never_faster: bool, ego_speed: float,
                  ov_speed: float, stopped: bool) -> float:  # fmt: skip
    """The path's wish: leg speed, anticipation of a slower next leg `to_end` metres on, caps
    and overrides; 0 when halted or waiting."""
    vt = cap if cap < v_leg else v_leg
    dist_end = to_end if to_end > 0.0 else 0.0
    if v_next < vt:
        v_allow = math.sqrt(v_next * v_next + dec_brake * dist_end)  # v^2 + 2 (0.5 decelerationBrake) dist
        vt = v_allow if v_allow < vt else vt
    if never_faster:
        ego = ego_speed if ego_speed > 0.0 else 0.0
        vt = ego if ego < vt else vt
    if not math.isnan(ov_speed):
        vt = ov_speed
    return 0.0 if stopped else vt


@kernel
def bend_speed(ang: float, d: float) -> float:
    """Speed at which the arc to the carrot stays within BEND_ACCEL_MPS2 of lateral acceleration.

    OpenDS's physical cars lose speed in turns they cannot make; a kinematic car would
    swing wide (or circle its carrot), so once the carrot lies more than 45 degrees off the
    heading (hairpins, overshot corners) it slows down: radius d / (2 sin(angle)), and the
    tightest one (d/2) when the carrot is beside or behind the car. Ordinary tracking, with
    small angles, is never slowed.
    """
    abs_ang = abs(ang)
    if not abs_ang > BEND_MIN_ANGLE_RAD:
        return math.inf
    s = abs(math.sin(ang)) if abs_ang < 0.5 * math.pi else 1.0
    radius = 0.5 * d / (s if s > 1e-9 else 1e-9)
    r = radius if radius > 0.5 * WHEELBASE_M else 0.5 * WHEELBASE_M
    return math.sqrt(BEND_ACCEL_MPS2 * r)


@inline
def _sees(x: float, z: float, fx: float, fz: float, ux: float, uz: float, fsafe: float, lat_safe: float, ox: float, oz: float) -> bool:
    """Does an object at (x, z), heading (fx, fz), next waypoint in direction (ux, uz), see the
    point (ox, oz) in its safety box: closer than `fsafe` ahead along its heading or toward
    its next waypoint, and within `lat_safe` across?"""
    rx, rz = ox - x, oz - z
    reach = fsafe + lat_safe
    if not rx * rx + rz * rz < reach * reach:
        return False
    f1, f2 = rx * fx + rz * fz, rx * ux + rz * uz
    if abs(rx * fz - rz * fx) < lat_safe and 0.0 < f1 < fsafe:
        return True
    return abs(rx * uz - rz * ux) < lat_safe and 0.0 < f2 < fsafe


@inline
def _longitudinal(v: float, vt: float, dt: float, engine_on: bool, accel: float, dec_brake: float, dec_free: float, friction: float,
                  ov_decel: float, ext: bool, ext_gas: float, ext_brake: float) -> tuple[float, bool]:  # fmt: skip
    """(new speed, braking) from OpenDS's pedal rule, overrides and external control."""
    vk, tk = 3.6 * v, 3.6 * vt
    below = v < vt
    above = vk > tk + 1.0
    if below:
        want = (vt - v) / dt
        a = (want if want < accel else accel) if engine_on else -friction
    elif above:
        brake = (vk - tk - 1.0) / 2.0
        brake = brake if brake > 0.0 else 0.0
        brake = brake if brake < 1.0 else 1.0
        a = -brake * dec_brake - friction
    else:
        a = -dec_free
    forced = math.isfinite(ov_decel) and v > vt
    if forced:
        a = -ov_decel
    if ext:
        a = (ext_gas * accel if engine_on else 0.0) - ext_brake * dec_brake - friction
    v_new = v + a * dt
    v_new = v_new if v_new > 0.0 else 0.0
    if forced and not ext and vt > v_new:
        v_new = vt
    if ext:
        return v_new, ext_brake > 0.0
    return v_new, (above and not below) or forced


@inline
def _move(x: float, z: float, yaw: float, steer: float, v_new: float, dt: float) -> tuple[float, float, float, float, float]:
    """The kinematic bicycle: (x, z, yaw) after `dt` at speed v_new and steering input `steer`,
    and the sine and cosine of the new yaw."""
    wheel = steer * MAX_WHEEL_ANGLE_RAD
    yaw = yaw + v_new / WHEELBASE_M * (wheel if wheel == 0.0 else math.tan(wheel)) * dt  # (tan(+-0) is +-0)
    turned = yaw + math.pi
    # Python's `%` (a C fmod call) is the identity on [0, 2 pi): skip it there, same floats
    yaw = (turned if 0.0 <= turned < TWO_PI else turned % TWO_PI) - math.pi
    sin_yaw, cos_yaw = sin_cos(yaw)
    return x - v_new * sin_yaw * dt, z - v_new * cos_yaw * dt, yaw, sin_yaw, cos_yaw


@inline
def _carrot(f: np.ndarray, i: np.ndarray, pos: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, work: np.ndarray,
            k: int) -> None:  # fmt: skip
    """Object k's carrot: its point on its path (`paths.sample_point`, written out), and its
    angle and distance from the object (with the kept sine and cosine of the object's yaw)."""
    pid = i[ts.I_PID, k]
    s, hint = f[ts.F_S, k], int(work[W_HINT, k])
    length = pp[PP_LEN, pid]
    g = pp[PP_OFF, pid] + ((s if s > 0.0 else 0.0) if s < length else length)
    first, last = pi[PI_FIRST, pid], pi[PI_LAST_PIECE, pid] + 1
    if first <= hint < last and pf[PF_S, hint] <= g < pf[PF_S, hint + 1]:
        p = hint
    elif first <= hint < last - 1 and pf[PF_S, hint + 1] <= g < pf[PF_S, hint + 2]:
        p = hint + 1
    else:
        p = piece_at(pf, first, last, g)
    p = p if p < last - 1 else last - 1
    u = (g - pf[PF_S, p]) / pf[PF_LEN, p] if pf[PF_OK, p] != 0.0 else 0.0
    cx, cz = pf[PF_X, p] + u * pf[PF_DX, p], pf[PF_Z, p] + u * pf[PF_DZ, p]
    work[W_HINT, k] = p
    work[W_CX, k], work[W_CY, k], work[W_CZ, k], work[W_CYAW, k] = cx, pf[PF_Y, p] + u * pf[PF_DY, p], cz, pf[PF_YAW, p]
    yaw = f[ts.F_YAW, k]
    if work[W_TRIG_OK, k] != 0.0 and yaw != 0.0 and work[W_TRIG_YAW, k] == yaw:
        sin_yaw, cos_yaw = work[W_SIN, k], work[W_COS, k]
    else:
        sin_yaw, cos_yaw = sin_cos(yaw)
        work[W_SIN, k], work[W_COS, k], work[W_TRIG_YAW, k], work[W_TRIG_OK, k] = sin_yaw, cos_yaw, yaw, 1.0
    work[W_ANG, k], work[W_D, k] = _aim(cx, cz, pos[k, 0], pos[k, 2], sin_yaw, cos_yaw)


@borrowing_kernel
def advance_carrots(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray,
                    pi: np.ndarray, group: int, active: np.ndarray, t_group: np.ndarray, dt: float, work: np.ndarray,
                    flags: np.ndarray) -> int:  # fmt: skip
    """Move every live carrot along its path (the first kernel of a traffic step).

    Returns NOTHING_LIVE; WAITS_OVER (nothing changed; `flags` marks the objects whose wait
    at a waypoint is over: Python ends those waits and calls again); or the number of
    carrots flagged ARRIVED at the end of their leg (Python decides what comes next).
    `active` selects the worlds that step (`group` objects each, at times `t_group`).
    """
    return _advance_rows(f, i, b, pos, sp, pf, pp, pi, group, active, t_group, dt, work, flags, 0, f.shape[1])


@inline
def _advance_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray,
                  pi: np.ndarray, group: int, active: np.ndarray, t_group: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray,
                  lo: int, hi: int) -> int:  # fmt: skip
    """`advance_carrots` for the objects lo..hi-1 (whole worlds)."""
    live = waits = 0
    for k in range(lo, hi):
        flags[k] = 0
        if active[k] and b[ts.B_ENABLED, k] and i[ts.I_PID, k] >= 0:
            flags[k] = LIVE
            live += 1
            if f[ts.F_WAIT_UNTIL, k] <= t_group[k // group] + 1e-9:
                flags[k] |= WAIT_OVER
                waits += 1
    if live == 0:
        return NOTHING_LIVE
    if waits:
        return WAITS_OVER
    arrived = 0
    for k in range(lo, hi):
        if not flags[k] & LIVE:
            continue
        _carrot(f, i, pos, pf, pp, pi, work, k)
        is_car, span_ok = sp[ts.S_IS_CAR, k] != 0.0, sp[ts.S_SPAN_OK, k] != 0.0
        d_lo, d_hi, span, cap = sp[ts.S_MIN_DIST, k], sp[ts.S_MAX_DIST, k], sp[ts.S_SPAN_SAFE, k], sp[ts.S_MAX_SPEED, k]
        cv = _carrot_speed(work[W_D, k], work[W_ANG, k], d_lo, d_hi, span_ok, span, is_car, f[ts.F_SPEED, k], f[ts.F_V_LEG, k], cap)
        work[W_CV, k] = cv
        if not b[ts.B_HALTED, k] and math.isnan(f[ts.F_WAIT_UNTIL, k]) and not b[ts.B_EXT, k]:
            flags[k] |= MOVING
            f[ts.F_S, k] = f[ts.F_S, k] + cv * dt
            if f[ts.F_S, k] >= f[ts.F_LEG_END, k] - 1e-9:
                flags[k] |= ARRIVED
                arrived += 1
    return arrived


@borrowing_kernel
def continue_on_network(f: np.ndarray, i: np.ndarray, b: np.ndarray, end_xz: np.ndarray, net: np.ndarray, quiet_cars: np.ndarray,
                        flags: np.ndarray) -> int:  # fmt: skip
    """Cars flagged ARRIVED that `quiet_cars` marks (road-network cars with no preferred
    segments) enter their next segment here, as `LegLogic._arrive` would, while nothing in
    it needs Python (`net`: `RoadNetwork.continuations`): no wait at the waypoint, no end
    point, jump, traffic light or random choice of the segment after. Their ARRIVED flag is
    cleared; the others keep it. Returns how many are left for Python."""
    return _continue_rows(f, i, b, end_xz, net, quiet_cars, flags, 0, len(flags))


@inline
def _continue_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, end_xz: np.ndarray, net: np.ndarray, quiet_cars: np.ndarray,
                   flags: np.ndarray, lo: int, hi: int) -> int:  # fmt: skip
    """`continue_on_network` for the objects lo..hi-1."""
    left = 0
    for k in range(lo, hi):
        if not flags[k] & ARRIVED or not quiet_cars[k]:
            left += 1 if flags[k] & ARRIVED else 0
            continue
        for_python = False
        for _ in range(32):  # (several short legs may pass in one step; `_arrive` takes 32 at most)
            if f[ts.F_S, k] < f[ts.F_LEG_END, k] - 1e-9:
                break
            nxt = i[ts.I_NEXT_SEG, k]
            if (net[i[ts.I_LEG, k], ts.N_END_WAITS] != 0.0 and not b[ts.B_WAITED, k]) or nxt < 0 or net[nxt, ts.N_QUIET] == 0.0:
                for_python = True
                break
            over = f[ts.F_S, k] - f[ts.F_LEG_END, k]
            i[ts.I_PID, k], f[ts.F_S, k], i[ts.I_LEG, k], f[ts.F_LEG_END, k] = int(net[nxt, ts.N_PATH]), over, nxt, net[nxt, ts.N_LENGTH]
            f[ts.F_V_LEG, k], i[ts.I_NEXT_SEG, k], f[ts.F_V_NEXT, k] = net[nxt, ts.N_SPEED], int(net[nxt, ts.N_NEXT]), net[nxt, ts.N_V_NEXT]
            end_xz[k, 0], end_xz[k, 1] = net[nxt, ts.N_END_X], net[nxt, ts.N_END_Z]
            b[ts.B_WAITED, k] = False
            # the attributes of the waypoint the segment starts from (`LegLogic._apply_wp`)
            if not math.isnan(net[nxt, ts.N_TURN]):
                i[ts.I_TURN_PATH, k] = int(net[nxt, ts.N_TURN])
            i[ts.I_BRAKE_PATH, k] = int(net[nxt, ts.N_BRAKE])
            if not math.isnan(net[nxt, ts.N_HEAD]):
                f[ts.F_HEAD_LIGHT, k] = net[nxt, ts.N_HEAD]
        if for_python:
            left += 1
        else:
            flags[k] &= ~ARRIVED
    return left


@inline
def _sort_world(pos: np.ndarray, lo: int, hi: int, work: np.ndarray) -> int:
    """Objects lo..hi-1 (one world) in order along the coordinate (x or z) they spread most
    on: `work[W_ORDER]` (kept from the step before, so an insertion sort has little to do;
    any order it holds that is not a permutation of lo..hi-1 is started afresh) and its
    inverse `work[W_RANK]`. Returns the axis (0: x, 2: z)."""
    x0 = x1 = pos[lo, 0]
    z0 = z1 = pos[lo, 2]
    for k in range(lo + 1, hi):
        x, z = pos[k, 0], pos[k, 2]
        x0, x1 = (x if x < x0 else x0), (x if x > x1 else x1)
        z0, z1 = (z if z < z0 else z0), (z if z > z1 else z1)
    axis = 0 if x1 - x0 >= z1 - z0 else 2
    for p in range(lo, hi):
        work[W_RANK, p] = -1.0
    for p in range(lo, hi):
        j = work[W_ORDER, p]
        if not lo <= j < hi or work[W_RANK, int(j)] != -1.0:
            for q in range(lo, hi):
                work[W_ORDER, q] = q
            break
        work[W_RANK, int(j)] = p
    for p in range(lo + 1, hi):
        j = work[W_ORDER, p]
        key = pos[int(j), axis]
        q = p - 1
        while q >= lo and pos[int(work[W_ORDER, q]), axis] > key:
            work[W_ORDER, q + 1] = work[W_ORDER, q]
            q -= 1
        work[W_ORDER, q + 1] = j
    for p in range(lo, hi):
        work[W_RANK, int(work[W_ORDER, p])] = p
    return axis


@inline
def _obstacles(f: np.ndarray, b: np.ndarray, pos: np.ndarray, group: int, active: np.ndarray, ego: np.ndarray, work: np.ndarray,
               flags: np.ndarray, first: int, end: int) -> None:  # fmt: skip
    """`blocked` of every car of an active world: an enabled object of its world, or that
    world's ego car, in its safety box; of two cars that see each other, the one listed first
    goes. Candidates are visited from the car outwards along a sorted coordinate (in larger
    worlds) and only as far as the car's reach: objects farther along it cannot be in the box
    (so the answer does not depend on the order of objects at the same coordinate).
    """
    sort = group > SORT_ABOVE
    for lo in range(first, end, group):
        hi = lo + group
        axis = _sort_world(pos, lo, hi, work) if sort else 0
        g = lo // group
        for k in range(lo, hi):
            if not active[k]:
                continue
            hit = False
            if flags[k] & CAR and not b[ts.B_EXT, k]:
                x, z, fsafe, lat = pos[k, 0], pos[k, 2], work[W_FSAFE, k], f[ts.F_LAT_SAFE, k]
                fx, fz, ux, uz = work[W_FX, k], work[W_FZ, k], work[W_UX, k], work[W_UZ, k]
                hit = _sees(x, z, fx, fz, ux, uz, fsafe, lat, ego[0, g], ego[1, g])
                reach = fsafe + lat
                at = int(work[W_RANK, k]) if sort else k
                for step in (-1, 1):
                    p = at + step
                    while not hit and lo <= p < hi:
                        j = int(work[W_ORDER, p]) if sort else p
                        p += step
                        if sort and abs(pos[j, axis] - pos[k, axis]) >= reach:
                            break
                        if j == k or not b[ts.B_ENABLED, j] or not _sees(x, z, fx, fz, ux, uz, fsafe, lat, pos[j, 0], pos[j, 2]):
                            continue
                        if flags[j] & CAR and not b[ts.B_EXT, j] and k < j and _sees(pos[j, 0], pos[j, 2], work[W_FX, j], work[W_FZ, j],
                                                                                      work[W_UX, j], work[W_UZ, j], work[W_FSAFE, j],
                                                                                      f[ts.F_LAT_SAFE, j], x, z):  # fmt: skip
                            continue  # they see each other: k goes
                        hit = True
            b[ts.B_BLOCKED, k] = hit


@borrowing_kernel
def drive(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray, ext_cmd: np.ndarray,
          sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, group: int, active: np.ndarray, ego: np.ndarray, dt: float,
          work: np.ndarray, flags: np.ndarray, resample: bool, stop_mask: np.ndarray) -> int:  # fmt: skip
    """The second kernel of a traffic step, after `advance_carrots` (and Python's leg events).

    Pedestrians walk on their carrots; cars: speed wish, obstacles (all seen before any car
    moves), red lights, give-way holds (flagged BLOCK by Python), pedals, steering and
    motion. `ego` (rows x, z, speed) is each world's ego car; `stop_mask` tells which
    traffic lights stop cars. `resample`: carrots moved since `advance_carrots` (leg
    events), so their points and angles are taken again. Returns how many cars passed the
    traffic light they were queued for (flagged PASSED_LIGHT for Python).
    """
    return _drive_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, group, active, ego, dt, work, flags, resample, stop_mask, 0,
                       f.shape[1])  # fmt: skip


@inline
def _drive_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, group: int, active: np.ndarray,
                ego: np.ndarray, dt: float, work: np.ndarray, flags: np.ndarray, resample: bool, stop_mask: np.ndarray, lo: int,
                hi: int) -> int:  # fmt: skip
    """`drive` for the objects lo..hi-1 (whole worlds)."""
    any_car = False
    for k in range(lo, hi):  # speed wishes, safety distances and headings, before anything moves
        if not flags[k] & LIVE:
            continue
        if resample:
            _carrot(f, i, pos, pf, pp, pi, work, k)
        if sp[ts.S_IS_CAR, k] == 0.0:  # a pedestrian stands on its carrot
            pos[k, 0], pos[k, 1], pos[k, 2] = work[W_CX, k], work[W_CY, k], work[W_CZ, k]
            f[ts.F_YAW, k] = work[W_CYAW, k]
            go = flags[k] & MOVING and not b[ts.B_HALTED, k] and math.isnan(f[ts.F_WAIT_UNTIL, k])
            f[ts.F_SPEED, k] = work[W_CV, k] if go else 0.0
            continue
        flags[k] |= CAR
        any_car = True
        stopped = b[ts.B_HALTED, k] or not math.isnan(f[ts.F_WAIT_UNTIL, k])
        to_end = f[ts.F_LEG_END, k] - (f[ts.F_S, k] - work[W_D, k])  # from the car (about d behind its carrot)
        vt = _target_speed(f[ts.F_V_LEG, k], sp[ts.S_MAX_SPEED, k], to_end, f[ts.F_V_NEXT, k], sp[ts.S_DEC_BRAKE, k],
                           sp[ts.S_NEVER_FASTER, k] != 0.0, ego[2, k // group], f[ts.F_OV_SPEED, k], stopped)  # fmt: skip
        vb = bend_speed(work[W_ANG, k], work[W_D, k])
        work[W_VT, k] = vb if vb < vt else vt
        # forward safety distance: max(minForward, 0.5 x speed in km/h), or minForward alone
        by_speed = 1.8 * f[ts.F_SPEED, k] if b[ts.B_SPEED_DEP, k] else 0.0
        work[W_FSAFE, k] = by_speed if by_speed > f[ts.F_MIN_FWD, k] else f[ts.F_MIN_FWD, k]
        fx, fz = -work[W_SIN, k], -work[W_COS, k]  # (of this yaw: `_carrot` took them this step)
        ux, uz = end_xz[k, 0] - pos[k, 0], end_xz[k, 1] - pos[k, 2]
        un = _dist(ux, uz)
        if un > 1e-6:
            inv = 1.0 / un
            ux, uz = ux * inv, uz * inv
        else:
            ux, uz = fx, fz
        work[W_FX, k], work[W_FZ, k], work[W_UX, k], work[W_UZ, k] = fx, fz, ux, uz
    if not any_car:
        return 0
    _obstacles(f, b, pos, group, active, ego, work, flags, lo, hi)
    passed = 0
    for k in range(lo, hi):
        if not flags[k] & CAR:
            continue
        block = b[ts.B_BLOCKED, k] or (flags[k] & BLOCK) != 0
        li = i[ts.I_LIGHT_IDX, k]
        if li >= 0 and stop_mask[li]:
            block = block or _dist(light_xz[k, 0] - pos[k, 0], light_xz[k, 1] - pos[k, 2]) < work[W_FSAFE, k]
        ext = b[ts.B_EXT, k]
        v_new, braking = _longitudinal(f[ts.F_SPEED, k], 0.0 if block else work[W_VT, k], dt, b[ts.B_ENGINE_ON, k], sp[ts.S_ACCEL, k],
                                       sp[ts.S_DEC_BRAKE, k], sp[ts.S_DEC_FREE, k], sp[ts.S_FRICTION, k], f[ts.F_OV_DECEL, k], ext,
                                       ext_cmd[k, 1], ext_cmd[k, 2])  # fmt: skip
        b[ts.B_BRAKING, k] = braking
        # steer toward the carrot: sign * min(1, 4 angle / pi) of the wheel lock (or as commanded)
        ang = work[W_ANG, k]
        q = 4.0 * abs(ang) / math.pi
        steer = ext_cmd[k, 0] if ext else (1.0 if ang > 0.0 else -1.0 if ang < 0.0 else 0.0) * (q if q < 1.0 else 1.0)
        pos[k, 0], pos[k, 2], yaw, sin_yaw, cos_yaw = _move(pos[k, 0], pos[k, 2], f[ts.F_YAW, k], steer, v_new, dt)
        f[ts.F_YAW, k] = yaw
        work[W_SIN, k], work[W_COS, k], work[W_TRIG_YAW, k], work[W_TRIG_OK, k] = sin_yaw, cos_yaw, yaw, 1.0
        f[ts.F_SPEED, k] = v_new
        pos[k, 1] = work[W_CY, k]
        if li >= 0:
            yaw = f[ts.F_YAW, k]
            ahead = -(light_xz[k, 0] - pos[k, 0]) * math.sin(yaw) - (light_xz[k, 1] - pos[k, 2]) * math.cos(yaw)
            if ahead < 0.0:
                flags[k] |= PASSED_LIGHT
                passed += 1
    return passed


@borrowing_kernel
def outputs(i: np.ndarray, b: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray) -> None:
    """Brake lights and turn signals: an override, else the path's setting, else braking."""
    _outputs_rows(i, b, brake_light, turn_signal, 0, i.shape[1])


@inline
def _outputs_rows(i: np.ndarray, b: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray, lo: int, hi: int) -> None:
    for k in range(lo, hi):
        ob, bp = i[ts.I_OV_BRAKE, k], i[ts.I_BRAKE_PATH, k]
        brake_light[k] = ob == 1 if ob >= 0 else bp == 1 if bp >= 0 else b[ts.B_BRAKING, k]
        ot = i[ts.I_OV_TURN, k]
        turn_signal[k] = ot if ot >= 0 else i[ts.I_TURN_PATH, k]


@kernel
def step_objects(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                 ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t_now: np.ndarray, ego: np.ndarray,
                 dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray,
                 net: np.ndarray, quiet_cars: np.ndarray) -> tuple[int, int]:  # fmt: skip
    """A whole traffic step of one world in one call when no object needs Python: `advance_carrots`,
    `continue_on_network` for the legs that ended, `drive`, `outputs`. Returns (the number of
    objects left for Python, flagged, or advance_carrots' negative code; lights passed); the
    second is -1 when the step stopped for Python (waits over, legs ended that need it)."""
    n = f.shape[1]
    return _step_world(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t_now, ego, dt, work, flags, stop_mask, brake_light,
                       turn_signal, net, quiet_cars, np.ones(n, dtype=np.bool_))  # fmt: skip


@borrowing_kernel
def _step_world(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                ext_cmd: np.ndarray, sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t_now: np.ndarray, ego: np.ndarray,
                dt: float, work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray,
                net: np.ndarray, quiet_cars: np.ndarray, active: np.ndarray) -> tuple[int, int]:  # fmt: skip
    n = f.shape[1]
    return step_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, t_now, ego, dt, work, flags, stop_mask, brake_light,
                     turn_signal, net, quiet_cars, n if n > 0 else 1, active, 0, n)  # fmt: skip


@inline
def step_rows(f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray, ext_cmd: np.ndarray,
              sp: np.ndarray, pf: np.ndarray, pp: np.ndarray, pi: np.ndarray, t_group: np.ndarray, ego: np.ndarray, dt: float,
              work: np.ndarray, flags: np.ndarray, stop_mask: np.ndarray, brake_light: np.ndarray, turn_signal: np.ndarray, net: np.ndarray,
              quiet_cars: np.ndarray, group: int, active: np.ndarray, lo: int, hi: int) -> tuple[int, int]:  # fmt: skip
    """`step_objects` for the objects lo..hi-1, one world of `group` objects (times `t_group`,
    ego cars `ego` by world; `active` must hold its rows), on the whole arrays: the native
    batch steps each world so, with no array views (each costs reference counting)."""
    code = _advance_rows(f, i, b, pos, sp, pf, pp, pi, group, active, t_group, dt, work, flags, lo, hi)
    moved_on = code > 0
    if moved_on:
        code = _continue_rows(f, i, b, end_xz, net, quiet_cars, flags, lo, hi)
    if code != 0:
        return code, -1
    passed = _drive_rows(f, i, b, pos, end_xz, light_xz, ext_cmd, sp, pf, pp, pi, group, active, ego, dt, work, flags, moved_on,
                         stop_mask, lo, hi)  # fmt: skip
    _outputs_rows(i, b, brake_light, turn_signal, lo, hi)
    return 0, passed
