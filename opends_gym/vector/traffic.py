"""Traffic cars of a native batch: N envs x C cars in one flat `MotionState` (row = env * C + car).

Why: `sim.traffic.TrafficManager.step` already does its per-step work as row-wise numpy
maths (`traffic_motion`), so the same functions run over all envs' cars at once; only the
obstacle search, which pairs each car with the other objects of *its* world, is written
here per env (same arithmetic, same "the one listed first goes" rule). Leg ends are rare
and run the single env's own `LegLogic` on the flat state. What the batched tasks use is
supported: cars on their own waypoint paths, no traffic lights, road network, pedestrians
or external control (`FlatTraffic` refuses others).
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

from ..sim.traffic_legs import KIND_OWN, LegLogic
from ..sim.traffic_motion import MotionState, Specs, bend_speed, carrot_angle, carrot_speed, longitudinal, steer_and_move, target_speed
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

    def __init__(self, tm: Any, n: int, ego_length_m: float, ego_half: tuple[float, float]) -> None:
        if tm.network is not None or tm.lights is not None or not tm.is_car.all() or np.any(tm.kind != KIND_OWN):
            raise ValueError("the native batch supports traffic cars on their own waypoint paths only")
        if np.any(tm.sp.never_faster) or np.any(tm._stuck_reset):
            raise ValueError("the native batch does not support neverFasterThanSteeringCar or resetWhenStuck")
        self.n, self.c = n, len(tm.ids)
        self.tm = tm
        self.paths = tm.paths
        self.st0 = tm.st.copy()  # after the template's reset (and the task's own reset of the cars)
        self.st = MotionState(**{f.name: np.concatenate([getattr(self.st0, f.name)] * n) for f in fields(MotionState) if f.init})
        self.sp = Specs(**{f.name: np.tile(getattr(tm.sp, f.name), n) for f in fields(Specs) if f.init})
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
        k = np.tile(np.arange(self.c), len(idx))
        for f in fields(MotionState):
            if f.init:
                getattr(self.st, f.name)[rows] = getattr(st0, f.name)[k]
        for r in rows.tolist():
            self.legs.light_queue[r] = []
        self.hitting[rows] = False

    # ------------------------------------------------------------------ step
    def step(self, live_env: np.ndarray, dt: float, t_env: np.ndarray, ex: np.ndarray, ez: np.ndarray) -> None:
        """`TrafficManager.step` for the cars of the envs `live_env` (ego positions ex, ez)."""
        st, sp = self.st, self.sp
        env_rows = np.repeat(live_env, self.c)
        live = env_rows & st.enabled & (st.pid >= 0)
        if not live.any():
            return
        moving = live & ~st.halted & np.isnan(st.wait_until) & ~st.ext
        cx, cy, cz, _ = self.paths.sample(np.maximum(st.pid, 0), st.s)
        ang, d = carrot_angle(st, cx, cz)
        cv = carrot_speed(st, sp, d, ang)
        st.s = np.where(moving, st.s + cv * dt, st.s)
        arrived = np.flatnonzero(moving & (st.s >= st.leg_end - 1e-9))
        for i in arrived.tolist():
            self.legs.t_s = float(t_env[i // self.c])
            self.legs._arrive(i)
        if arrived.size:
            cx, cy, cz, _ = self.paths.sample(np.maximum(st.pid, 0), st.s)
            ang, d = carrot_angle(st, cx, cz)
        cars = live
        vt = np.minimum(target_speed(st, sp, d, 0.0), bend_speed(ang, d))
        st.blocked = np.where(env_rows, self._obstacles(cars & ~st.ext, ex, ez), st.blocked)
        vt = np.where(st.blocked, 0.0, vt)
        v_new, braking = longitudinal(st, sp, vt, dt)
        st.braking = np.where(cars, braking, st.braking)
        steer_and_move(st, cars, ang, v_new, dt)
        st.pos[:, 1] = np.where(cars, cy, st.pos[:, 1])

    def _obstacles(self, rows: np.ndarray, ex: np.ndarray, ez: np.ndarray) -> np.ndarray:
        """`traffic_motion.obstacles` per env: each car against its world's other cars and ego."""
        st, c = self.st, self.c
        fsafe = np.maximum(st.min_fwd, 0.5 * 3.6 * st.speed * st.speed_dep)
        reach = fsafe + st.lat_safe
        px, pz = st.pos[:, 0].reshape(-1, c), st.pos[:, 2].reshape(-1, c)
        ox = np.concatenate([px, ex[:, None]], axis=1)  # (n, c + 1): the cars, then the ego car
        oz = np.concatenate([pz, ez[:, None]], axis=1)
        en = np.concatenate([st.enabled.reshape(-1, c), np.ones((self.n, 1), dtype=bool)], axis=1)
        fx, fz = -np.sin(st.yaw), -np.cos(st.yaw)
        ux, uz = st.end_xz[:, 0] - st.pos[:, 0], st.end_xz[:, 1] - st.pos[:, 2]
        un = np.hypot(ux, uz)
        ok = un > 1e-6
        inv = np.divide(1.0, un, out=np.zeros_like(un), where=ok)
        ux, uz = np.where(ok, ux * inv, fx), np.where(ok, uz * inv, fz)
        hit = np.zeros((self.n * c, c + 1), dtype=bool)
        for b in range(c + 1):
            rx = np.repeat(ox[:, b], c) - st.pos[:, 0]
            rz = np.repeat(oz[:, b], c) - st.pos[:, 2]
            near = (rx * rx + rz * rz < reach * reach) & np.repeat(en[:, b], c) & rows
            if b < c:
                near &= np.tile(np.arange(c), self.n) != b
            f1, f2 = rx * fx + rz * fz, rx * ux + rz * uz
            h = (np.abs(rx * fz - rz * fx) < st.lat_safe) & (f1 > 0.0) & (f1 < fsafe)
            h |= (np.abs(rx * uz - rz * ux) < st.lat_safe) & (f2 > 0.0) & (f2 < fsafe)
            hit[:, b] = near & h
        out = np.zeros(self.n * c, dtype=bool)
        own = np.tile(np.arange(c), self.n)
        for b in range(c + 1):
            blocked_by = hit[:, b]
            if b < c:  # mutual waiting: the car listed first goes
                other = (np.arange(self.n * c) // c) * c + b
                mutual = (own < b) & rows[other] & hit[other, own]
                blocked_by &= ~mutual
            out |= blocked_by
        return out & rows

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
        st = self.st
        brake = np.where(st.ov_brake >= 0, st.ov_brake == 1, np.where(st.brake_path >= 0, st.brake_path == 1, st.braking))
        return brake, np.where(st.ov_turn >= 0, st.ov_turn, st.turn_path)

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
        """The kinematics observation's nearest-vehicle slots (K x 6 per env)."""
        st, c = self.st, self.c
        fx, fz = -np.sin(yaw)[:, None], -np.cos(yaw)[:, None]
        lx, lz = -np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        dx = st.pos[:, 0].reshape(-1, c) - x[:, None]
        dz = st.pos[:, 2].reshape(-1, c) - z[:, None]
        dist = np.where(st.enabled.reshape(-1, c), np.hypot(dx, dz), np.inf)
        order = np.argsort(dist, axis=1, kind="stable")[:, :k]
        brake, turn = self.outputs()
        vyaw = st.yaw.reshape(-1, c)
        v_along = st.speed.reshape(-1, c) * (-np.sin(vyaw) * fx - np.cos(vyaw) * fz)
        out = np.zeros((self.n, k * 6))
        ar = np.arange(self.n)
        for slot in range(min(k, c)):
            j = order[:, slot]
            on = np.isfinite(dist[ar, j])
            cols = np.stack(
                [
                    np.ones(self.n),
                    dx[ar, j] * fx[:, 0] + dz[ar, j] * fz[:, 0],
                    dx[ar, j] * lx[:, 0] + dz[ar, j] * lz[:, 0],
                    v_along[ar, j] - u,
                    brake.reshape(-1, c)[ar, j].astype(float),
                    turn.reshape(-1, c)[ar, j].astype(float),
                ],
                axis=1,
            )
            out[:, slot * 6 : slot * 6 + 6] = np.where(on[:, None], cols, 0.0)  # sorted: a disabled car ends the list
        return out
