"""The traffic objects' state and fixed parameters, one row (array element) per object.

Why: the per-step traffic maths is a compiled kernel (`traffic.motion`) that reads and
writes these arrays. A kernel call costs about 0.1 us per argument, so the state is packed
into a few 2D arrays (floats, ints, bools, plus the vector-valued fields), and every named
field (`st.speed`, `st.pid`, ...) is a view of one row of them: Python code (leg events,
commands, the native batch) reads and writes fields by name as before, the kernel sees the
same memory. Assigning a whole field (`st.s = ...`) copies into its row.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

FLOAT_FIELDS = ("yaw", "speed", "s", "leg_end", "v_leg", "v_next", "wait_until", "head_light", "ov_speed", "ov_decel", "min_fwd",
                "lat_safe", "lane_hold_until")  # fmt: skip
INT_FIELDS = ("pid", "leg", "next_seg", "light_idx", "turn_path", "brake_path", "ov_brake", "ov_turn", "stuck_n")
BOOL_FIELDS = ("enabled", "engine_on", "waited", "halted", "braking", "blocked", "ext", "speed_dep")
VECTOR_FIELDS = ("pos", "end_xz", "light_xz", "ext_cmd", "stuck_hist")
# rows of the packed arrays, for the kernels
F_YAW, F_SPEED, F_S, F_LEG_END, F_V_LEG, F_V_NEXT, F_WAIT_UNTIL, F_HEAD_LIGHT, F_OV_SPEED, F_OV_DECEL, F_MIN_FWD, F_LAT_SAFE = range(12)
I_PID, I_LEG, I_NEXT_SEG, I_LIGHT_IDX, I_TURN_PATH, I_BRAKE_PATH, I_OV_BRAKE, I_OV_TURN, I_STUCK_N = range(9)
B_ENABLED, B_ENGINE_ON, B_WAITED, B_HALTED, B_BRAKING, B_BLOCKED, B_EXT, B_SPEED_DEP = range(8)
_DEFAULTS: dict[str, Any] = {"wait_until": np.nan, "ov_speed": np.nan, "ov_decel": np.nan, "min_fwd": 8.0, "lat_safe": 2.0,
                             "lane_hold_until": -1.0, "pid": -1, "next_seg": -1, "light_idx": -1, "brake_path": -1, "ov_brake": -1,
                             "ov_turn": -1, "enabled": True, "engine_on": True, "speed_dep": True}  # fmt: skip
_PACKED = {name: ("f", k) for k, name in enumerate(FLOAT_FIELDS)} | {name: ("i", k) for k, name in enumerate(INT_FIELDS)}
_PACKED |= {name: ("b", k) for k, name in enumerate(BOOL_FIELDS)}


class MotionState:
    """Everything about the objects that changes during a run (see the module docstring).

    pos (N,3) world metres; yaw rad; speed m/s; pid: current path id (-1: no route); s: the
    carrot's arc length on it; leg: Gen A leg index / Gen B segment index; next_seg: Gen B
    segment after this one (-1 end point); leg_end: arc length where the leg ends; end_xz
    (N,2): the leg's end waypoint; wait_until: NaN unless waiting at a waypoint; waited: the
    wait at the current leg end is over; halted: at an end point for good; light_idx: next
    lighted waypoint's light (-1 none) at light_xz; brake_path: -1 not set by the path, 0
    off, 1 on; blocked: an obstacle within the safety distance; ov_*: overrides (NaN / -1
    none); ext_cmd (N,3): steering, accelerator, brake under external control; stuck_hist
    (N,7,2): positions once a second; lane_hold_until: a requested lane change suspends
    automatic lane choice until then.
    """

    f: np.ndarray
    i: np.ndarray
    b: np.ndarray
    pos: np.ndarray
    end_xz: np.ndarray
    light_xz: np.ndarray
    ext_cmd: np.ndarray
    stuck_hist: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray
    s: np.ndarray
    leg_end: np.ndarray
    v_leg: np.ndarray
    v_next: np.ndarray
    wait_until: np.ndarray
    head_light: np.ndarray
    ov_speed: np.ndarray
    ov_decel: np.ndarray
    min_fwd: np.ndarray
    lat_safe: np.ndarray
    lane_hold_until: np.ndarray
    pid: np.ndarray
    leg: np.ndarray
    next_seg: np.ndarray
    light_idx: np.ndarray
    turn_path: np.ndarray
    brake_path: np.ndarray
    ov_brake: np.ndarray
    ov_turn: np.ndarray
    stuck_n: np.ndarray
    enabled: np.ndarray
    engine_on: np.ndarray
    waited: np.ndarray
    halted: np.ndarray
    braking: np.ndarray
    blocked: np.ndarray
    ext: np.ndarray
    speed_dep: np.ndarray

    def __init__(self, f: np.ndarray, i: np.ndarray, b: np.ndarray, pos: np.ndarray, end_xz: np.ndarray, light_xz: np.ndarray,
                 ext_cmd: np.ndarray, stuck_hist: np.ndarray) -> None:  # fmt: skip
        put = object.__setattr__
        for name, value in (("f", f), ("i", i), ("b", b)):  # (an object-major layout, `car_major`, is kept)
            put(self, name, value if value.flags.f_contiguous and not value.flags.c_contiguous else np.ascontiguousarray(value))
        for name, value in (("pos", pos), ("end_xz", end_xz), ("light_xz", light_xz), ("ext_cmd", ext_cmd)):
            put(self, name, np.ascontiguousarray(value))
        put(self, "stuck_hist", np.ascontiguousarray(stuck_hist))
        for name, (kind, k) in _PACKED.items():
            put(self, name, getattr(self, kind)[k])

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _PACKED:
            getattr(self, name)[...] = value  # in place: the packed array is what the kernels see
        elif name in VECTOR_FIELDS:
            getattr(self, name)[...] = value
        else:
            object.__setattr__(self, name, value)

    def __reduce__(self) -> tuple[Any, ...]:  # (deepcopy and pickle rebuild the row views)
        return (MotionState, (self.f, self.i, self.b, self.pos, self.end_xz, self.light_xz, self.ext_cmd, self.stuck_hist))

    def __len__(self) -> int:
        return int(self.f.shape[1])

    @staticmethod
    def empty(n: int) -> MotionState:
        f = np.zeros((len(FLOAT_FIELDS), n))
        i = np.zeros((len(INT_FIELDS), n), dtype=np.int64)
        b = np.zeros((len(BOOL_FIELDS), n), dtype=bool)
        st = MotionState(f, i, b, np.zeros((n, 3)), np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 3)), np.zeros((n, 7, 2)))
        for name, value in _DEFAULTS.items():
            setattr(st, name, value)
        return st

    def copy(self) -> MotionState:
        return MotionState(*(a.copy(order="K") for a in self.__reduce__()[1]))

    def car_major(self) -> MotionState:
        """A copy whose packed arrays (f, i, b) hold each object's fields together (Fortran
        order; the same [field, object] indexing). Why: a native batch steps its worlds one
        after another, each object's whole step at a time; in the field-major layout that
        step reads ~40 fields from ~40 rows (cache lines) far apart, in this one from a few
        adjacent lines (the platoon batch's traffic cars alone: ~925 -> ~670 CPU ns per env-step,
        `benchmarks/native_tasks.py --parts`, docs/performance.md)."""
        a = self.__reduce__()[1]
        return MotionState(*(np.asfortranarray(x) for x in a[:3]), *(x.copy() for x in a[3:]))

    def tile(self, n: int) -> MotionState:
        """This state repeated n times (row k of copy j is row k of this one)."""
        a = self.__reduce__()[1]
        return MotionState(*(np.tile(x, (1, n)) for x in a[:3]), *(np.concatenate([x] * n) for x in a[3:]))

    def assign_rows(self, rows: np.ndarray, src: MotionState, src_rows: np.ndarray) -> None:
        """Rows `rows` of this state := rows `src_rows` of `src`."""
        mine, theirs = self.__reduce__()[1], src.__reduce__()[1]
        for a, b in zip(mine[:3], theirs[:3]):
            a[:, rows] = b[:, src_rows]
        for a, b in zip(mine[3:], theirs[3:]):
            a[rows] = b[src_rows]


# columns of `RoadNetwork.continuations` (one row per road-network segment): what a car
# entering the segment takes on, for the kernel that moves cars from leg to leg without Python
(N_PATH, N_LENGTH, N_SPEED, N_NEXT, N_V_NEXT, N_END_X, N_END_Z, N_TURN, N_BRAKE, N_HEAD, N_QUIET,
 N_END_WAITS) = range(12)  # fmt: skip
N_COLUMNS = 12
NEXT_DRAWN = -2  # N_NEXT when several segments leave the end waypoint: drawn by Python (world rng)

# rows of `Specs.packed`
S_ACCEL, S_DEC_BRAKE, S_DEC_FREE, S_MIN_DIST, S_MAX_DIST, S_MAX_SPEED, S_SPAN_OK, S_SPAN_SAFE, S_FRICTION, S_IS_CAR, S_NEVER_FASTER = range(
    11
)
FRICTION_SHARE = 0.2  # OpenDS always applies 0.2 x the free-wheel force as friction


@dataclass(frozen=True)
class Specs:
    """Fixed per-object parameters (from the task), one row each; `packed` holds them (and
    the terms derived from them) as one float array for the kernels."""

    is_car: np.ndarray
    accel: np.ndarray
    dec_brake: np.ndarray
    dec_free: np.ndarray
    min_dist: np.ndarray
    max_dist: np.ndarray
    max_speed: np.ndarray
    never_faster: np.ndarray
    packed: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        span = self.max_dist - self.min_dist
        ok = span > 1e-6
        rows = (self.accel, self.dec_brake, self.dec_free, self.min_dist, self.max_dist, self.max_speed, ok, np.where(ok, span, 1.0),
                FRICTION_SHARE * self.dec_free, self.is_car, self.never_faster)  # fmt: skip
        packed = np.array([np.asarray(r, dtype=np.float64) for r in rows]).reshape(len(rows), len(self.is_car))
        object.__setattr__(self, "packed", packed)  # (a frozen dataclass's derived field)
