"""Traffic cars of a native batch: N envs x C cars in one flat `MotionState` (row = env * C + car).

Why: `sim.traffic.TrafficManager.step` runs two compiled kernels (`traffic.motion`) over
its objects; here the same kernels run over all envs' cars at once, with `group = C` so
that each car meets only the objects and the ego car of *its* world. Leg ends are rare
and run the single env's own `LegLogic` on the flat state. What the batched tasks use is
supported: cars on their own waypoint paths, no traffic lights, road network, pedestrians
or external control (`FlatTraffic` refuses others).
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

from ..sim.traffic.legs import KIND_OWN, LegLogic
from ..sim.traffic.motion import ARRIVED, N_WORK, NOTHING_LIVE, WAIT_OVER, WAITS_OVER, advance_carrots, drive, outputs
from ..sim.traffic.queries import nearest_slots
from ..sim.traffic.state import MotionState, Specs
from .triggers import obb_overlap


class _Legs(LegLogic):
    """The single env's leg logic, pointed at the flat state."""

    def __init__(self, tm: Any, st: MotionState, n: int) -> None:
        c = len(tm.ids)
        self.world = tm.world
        self.st = st
        self.paths = tm.paths
        self.network = None
        self.own = list(tm.own) * n
        self.kind = np.tile(tm.kind, n)
        self.preferred = list(tm.preferred) * n
        self.light_queue = [[] for _ in range(n * c)]
        self.lights = None
        self.t_s = 0.0
        self.ids = tuple(tm.ids) * n


class FlatTraffic:
    """The traffic of N envs (C cars each), stepped together."""

    def __init__(self, tm: Any, n: int, ego_length_m: float, ego_half: tuple[float, float], car_major: bool = False) -> None:
        """`car_major`: the state, specs and work rows in each car's own columns (Fortran
        order, `MotionState.car_major`), for a batch that steps one world at a time
        (`platoon_pass`); the kernels index them alike, so the floats are the same."""
        if tm.network is not None or tm.lights is not None or not tm.is_car.all() or np.any(tm.kind != KIND_OWN):
            raise ValueError("the native batch supports traffic cars on their own waypoint paths only")
        if np.any(tm.sp.never_faster) or np.any(tm._stuck_reset):
            raise ValueError("the native batch does not support neverFasterThanSteeringCar or resetWhenStuck")
        self.n, self.c = n, len(tm.ids)
        self.tm = tm
        self.paths = tm.paths
        self.st0 = tm.st.copy()  # after the template's reset (and the task's own reset of the cars)
        self.st = self.st0.tile(n).car_major() if car_major else self.st0.tile(n)
        self.sp = Specs(**{f.name: np.tile(getattr(tm.sp, f.name), n) for f in fields(Specs) if f.init})
        self.sp_packed = np.asfortranarray(self.sp.packed) if car_major else self.sp.packed  # (what the kernels read)
        self.work = np.zeros((N_WORK, n * self.c), order="F" if car_major else "C")
        self.flags = np.zeros(n * self.c, dtype=np.int64)
        self.no_lights = np.zeros(1, dtype=bool)
        self.legs = _Legs(tm, self.st, n)
        self.half = np.tile(tm.half_extents, (n, 1))
        self.ego_length = ego_length_m
        self.ego_reach = math.hypot(*ego_half)
        self.reach = self.ego_reach + np.hypot(self.half[:, 0], self.half[:, 1])
        self.hitting = np.zeros(n * self.c, dtype=bool)

    def rows_of(self, idx: np.ndarray) -> np.ndarray:
        return (np.asarray(idx)[:, None] * self.c + np.arange(self.c)[None, :]).ravel()

    def reset_rows(self, idx: np.ndarray, st0: MotionState) -> None:
        rows = self.rows_of(idx)
        self.st.assign_rows(rows, st0, np.tile(np.arange(self.c), len(idx)))
        queue = self.legs.light_queue
        for r in rows.tolist():
            if queue[r]:  # (replaced only when used: fewer objects for Python's garbage collector)
                queue[r] = []
        self.hitting[rows] = False

    # ------------------------------------------------------------------ step
    def step(self, live_env: np.ndarray, dt: float, t_env: np.ndarray, ex: np.ndarray, ez: np.ndarray) -> None:
        """`TrafficManager.step` for the cars of the envs `live_env` (ego positions ex, ez): its
        kernels, with `group` = the cars of one env."""
        st, c, work, flags = self.st, self.c, self.work, self.flags
        active = np.repeat(live_env, c)
        pf, pp, pi = self.paths.arrays()
        t = np.ascontiguousarray(t_env, dtype=np.float64)
        code = advance_carrots(st.f, st.i, st.b, st.pos, self.sp_packed, pf, pp, pi, c, active, t, dt, work, flags)
        if code == NOTHING_LIVE:
            return
        if code == WAITS_OVER:
            for i in np.flatnonzero(flags & WAIT_OVER).tolist():
                self.legs.t_s = float(t_env[i // c])
                self.legs._finish_wait(i)
            pf, pp, pi = self.paths.arrays()
            code = advance_carrots(st.f, st.i, st.b, st.pos, self.sp_packed, pf, pp, pi, c, active, t, dt, work, flags)
        if code > 0:
            for i in np.flatnonzero(flags & ARRIVED).tolist():
                self.legs.t_s = float(t_env[i // c])
                self.legs._arrive(i)
            pf, pp, pi = self.paths.arrays()
        ego = np.zeros((3, self.n))  # x, z, speed (no car here watches the ego's speed)
        ego[0], ego[1] = ex, ez
        drive(st.f, st.i, st.b, st.pos, st.end_xz, st.light_xz, st.ext_cmd, self.sp_packed, pf, pp, pi, c, active, ego, dt, work, flags,
              code > 0, self.no_lights)  # fmt: skip

    # ------------------------------------------------------------------ ego relations
    def new_hits(self, live_env: np.ndarray, bx: np.ndarray, bz: np.ndarray, byaw: np.ndarray, half: tuple[float, float]) -> np.ndarray:
        """Collisions that begin this step, per env (`World._contacts` with traffic)."""
        st, c = self.st, self.c
        ex, ez, eyaw = np.repeat(bx, c), np.repeat(bz, c), np.repeat(byaw, c)
        near = st.enabled & (np.hypot(st.pos[:, 0] - ex, st.pos[:, 2] - ez) < self.reach) & np.repeat(live_env, c)
        hits = np.zeros(self.n * c, dtype=bool)
        r = np.flatnonzero(near)
        if r.size:
            hits[r] = obb_overlap(
                ex[r], ez[r], eyaw[r], half[0], half[1], st.pos[r, 0], st.pos[r, 2], st.yaw[r], self.half[r, 0], self.half[r, 1]
            )
        rows = np.repeat(live_env, c)
        new = hits & ~self.hitting & rows
        self.hitting = np.where(rows, hits, self.hitting)
        return new.reshape(-1, c).sum(axis=1)

    def outputs(self) -> tuple[np.ndarray, np.ndarray]:
        """(brake_light, turn_signal) per car row (`TrafficControls._refresh_outputs`)."""
        brake, turn = np.empty(self.n * self.c, dtype=bool), np.empty(self.n * self.c, dtype=np.int64)
        outputs(self.st.i, self.st.b, brake, turn)
        return brake, turn

    def lead(self, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`perception.lead_vehicle` per env: (car index or -1, gap m, speed along m/s, length m)."""
        st, c = self.st, self.c
        fx, fz = -np.sin(yaw), -np.cos(yaw)
        lx, lz = -np.cos(yaw), np.sin(yaw)
        dx = st.pos[:, 0].reshape(-1, c) - x[:, None]
        dz = st.pos[:, 2].reshape(-1, c) - z[:, None]
        ahead = dx * fx[:, None] + dz * fz[:, None]
        side = dx * lx[:, None] + dz * lz[:, None]
        ok = st.enabled.reshape(-1, c) & (ahead > 0.0) & (np.abs(side) <= 1.5) & (ahead < 200.0)
        j = np.argmin(np.where(ok, ahead, np.inf), axis=1)
        found = ok.any(axis=1)
        rows = np.arange(self.n) * c + j
        half_len = self.half[rows, 1]
        gap = ahead[np.arange(self.n), j] - half_len - 0.5 * self.ego_length
        vyaw = st.yaw[rows]
        v_along = st.speed[rows] * (-np.sin(vyaw) * fx - np.cos(vyaw) * fz)
        return np.where(found, j, -1), gap, v_along, 2.0 * half_len

    def slots(self, k: int, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The kinematics observation's nearest-vehicle slots (K x 6 per env): the single env's
        kernel, one world per env."""
        st = self.st
        brake, turn = self.outputs()
        out = np.empty((self.n, k * 6))
        nearest_slots(st.pos, st.yaw, st.speed, st.enabled, brake, turn, self.c, np.stack([x, z, yaw, u]), k, out, 0)
        return out
