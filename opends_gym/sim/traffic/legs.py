"""The rare per-object events of traffic: legs that end, waits, jumps, teleports, lane changes.

Why: the vectorised step only moves carrots along the current leg; when a carrot reaches a
leg's end (a waypoint), Python decides what comes next, exactly as OpenDS's FollowBox
does: wait there (`waitingTime`), take the next waypoint (Gen A; an open path restarts at
its first waypoint, a cyclic one closes), take the next segment (Gen B, drawn with the
World's seeded rng), jump (`jump` segments teleport), or stop for good at an end point.
Waypoint attributes (turn signal, brake light, head light) apply from the waypoint on;
the next waypoint's traffic light is queued until the car has passed it.

`LegLogic` is mixed into `TrafficManager`, which owns the attributes used here.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from ..ego.car import EgoCar
from .paths import PathBank
from .routes import OwnPath, RoadNetwork, WaypointInfo
from .state import MotionState


class LegWorld(Protocol):
    """What the leg logic reads of its World: the seeded generator (random forks) and the ego
    car (clearance checks before a lane change)."""

    rng: np.random.Generator
    ego: EgoCar


KIND_NONE, KIND_OWN, KIND_NET, KIND_OD = -1, 0, 1, 2
LANE_CHANGE_AHEAD_M = 30.0  # OpenDS joins the neighbour segment 30 m further on
LANE_HOLD_S = 10.0  # after a requested lane change the car keeps that lane at least this long
CLEAR_BEHIND_M, CLEAR_AHEAD_M = 20.0, 40.0


class LegLogic:
    world: LegWorld
    st: MotionState
    paths: PathBank
    network: RoadNetwork | None
    own: list[OwnPath | None]
    kind: np.ndarray
    preferred: list[frozenset[int]]
    light_queue: list[list[tuple[int, float, float]]]
    lights: Any
    t_s: float
    ids: tuple[str, ...]

    # ------------------------------------------------------------------ legs
    def _set_own_leg(self, i: int, k: int, apply_from: bool = True) -> None:
        o = self.own[i]
        assert o is not None
        st, n = self.st, len(o.wps)
        j = (k + 1) % n
        st.leg[i], st.leg_end[i] = k, o.wp_s[k + 1]
        st.v_leg[i], st.v_next[i] = o.speed[k], o.speed[j]
        st.end_xz[i] = (o.wps[j].xyz[0], o.wps[j].xyz[2])
        st.waited[i] = False
        if apply_from:
            self._apply_wp(i, o.wps[k])
        self._push_light(i, o.wps[j])

    def _enter_segment(self, i: int, k: int, s0: float, apply_from: bool = True) -> None:
        net = self.network
        assert net is not None
        st, seg = self.st, net.segments[k]
        st.pid[i], st.s[i], st.leg[i], st.leg_end[i] = seg.path, s0, k, seg.length
        st.v_leg[i] = seg.speed
        nxt = net.choose_next(seg.to_wp, self.preferred[i], self.world.rng)
        st.next_seg[i] = nxt
        st.v_next[i] = 0.0 if nxt < 0 else (seg.speed if net.segments[nxt].jump else net.segments[nxt].speed)
        to = net.waypoints[seg.to_wp]
        st.end_xz[i] = (to.xyz[0], to.xyz[2])
        st.waited[i] = False
        if apply_from:
            self._apply_wp(i, net.waypoints[seg.from_wp])
        self._push_light(i, to)

    def _leg_end_wp(self, i: int) -> WaypointInfo | None:
        k = int(self.st.leg[i])
        if self.kind[i] == KIND_OWN:
            o = self.own[i]
            assert o is not None
            return o.wps[(k + 1) % len(o.wps)]
        if self.kind[i] == KIND_NET:
            assert self.network is not None
            return self.network.waypoints[self.network.segments[k].to_wp]
        return None

    def _arrive(self, i: int) -> None:
        """The carrot reached the end of its leg: wait, continue, jump or stop."""
        st = self.st
        for _ in range(32):  # several short legs may pass in one step
            if st.s[i] < st.leg_end[i] - 1e-9 or st.halted[i] or not math.isnan(st.wait_until[i]):
                return
            end = self._leg_end_wp(i)
            if end is not None and end.waiting_s > 0.0 and not st.waited[i]:
                st.wait_until[i], st.s[i] = self.t_s + end.waiting_s, st.leg_end[i]
                return
            over = float(st.s[i] - st.leg_end[i])
            if self.kind[i] == KIND_OWN:
                self._next_own(i, over)
            elif self.kind[i] == KIND_NET:
                self._next_segment(i, over)
            else:  # an OpenDRIVE route has one leg: its end is the target
                st.halted[i], st.s[i] = True, st.leg_end[i]

    def _finish_wait(self, i: int) -> None:
        self.st.wait_until[i] = np.nan
        self.st.waited[i] = True
        self._arrive(i)

    def _next_own(self, i: int, over: float) -> None:
        o = self.own[i]
        assert o is not None
        n, j = len(o.wps), int(self.st.leg[i]) + 1
        if not o.cyclic and j >= n - 1:
            self._place_own(i, 0)  # the end of an open path: start again at waypoint 0
        elif o.cyclic and j >= n:
            self.st.s[i] = o.wp_s[0] + over
            self._set_own_leg(i, 0)
        else:
            self._set_own_leg(i, j)

    def _next_segment(self, i: int, over: float) -> None:
        net, st = self.network, self.st
        assert net is not None
        k = int(st.next_seg[i])
        if k < 0:
            st.halted[i], st.s[i] = True, st.leg_end[i]
            self._apply_wp(i, net.waypoints[net.segments[int(st.leg[i])].to_wp])
        elif net.segments[k].jump:
            self._place_net(i, net.segments[k].to_wp)
        else:
            self._enter_segment(i, k, over)

    # ------------------------------------------------------------------ placing
    def _clear_progress(self, i: int) -> None:
        st = self.st
        st.wait_until[i], st.waited[i], st.halted[i] = np.nan, False, False
        self.light_queue[i] = []
        st.light_idx[i] = -1

    def _place_car(self, i: int) -> None:
        """Put the object on its carrot, facing along the path (its speed is kept)."""
        x, y, z, yaw = self.paths.point(int(self.st.pid[i]), float(self.st.s[i]))
        self.st.pos[i] = (x, y, z)
        self.st.yaw[i] = yaw
        self.st.stuck_n[i] = 0

    def _place_own(self, i: int, k: int) -> None:
        o = self.own[i]
        assert o is not None
        self._clear_progress(i)
        self.st.pid[i] = o.path
        if not o.cyclic and k >= len(o.wps) - 1:  # at the last waypoint: the restart follows at once
            self.st.s[i] = o.wp_s[-1]
            self._set_own_leg(i, len(o.wps) - 2, apply_from=False)
            self._apply_wp(i, o.wps[-1])
        else:
            self.st.s[i] = o.wp_s[k]
            self._set_own_leg(i, k)
        self._place_car(i)

    def _place_net(self, i: int, wp: str) -> bool:
        net = self.network
        assert net is not None
        start = net.start_on(wp, self.preferred[i], self.world.rng)
        if start is None:
            return False
        self._clear_progress(i)
        self._enter_segment(i, start[0], start[1])
        if wp in net.waypoints:
            self._apply_wp(i, net.waypoints[wp])
        self._place_car(i)
        return True

    # ------------------------------------------------------------------ waypoint effects
    def _apply_wp(self, i: int, w: WaypointInfo) -> None:
        st = self.st
        if w.turn_signal is not None:
            st.turn_path[i] = w.turn_signal
        st.brake_path[i] = -1 if w.brake_light is None else int(w.brake_light)
        if w.head_light is not None:
            st.head_light[i] = max(0.0, w.head_light)

    def _push_light(self, i: int, w: WaypointInfo) -> None:
        if w.light is None or self.lights is None:
            return
        li = self.lights.index_of(w.light)
        if li is None:
            return
        q = self.light_queue[i]
        q.append((int(li), w.xyz[0], w.xyz[2]))
        if len(q) == 1:
            self.st.light_idx[i], self.st.light_xz[i] = q[0][0], q[0][1:]

    def _pop_light(self, i: int) -> None:
        q = self.light_queue[i]
        if q:
            q.pop(0)
        self.st.light_idx[i] = q[0][0] if q else -1
        if q:
            self.st.light_xz[i] = q[0][1:]

    # ------------------------------------------------------------------ neighbours
    def _lane_clear(self, i: int, k: int) -> bool:
        """No traffic (nor the ego car) near the stretch of segment k the object would join."""
        net, st = self.network, self.st
        assert net is not None
        seg = net.segments[k]
        cur = net.segments[int(st.leg[i])]
        s_n = (float(st.s[i]) / cur.length if cur.length > 0 else 0.0) * seg.length
        pts = self.paths.window(seg.path, s_n - CLEAR_BEHIND_M, s_n + CLEAR_AHEAD_M)
        ego = self.world.ego.state
        others = np.flatnonzero(st.enabled & (np.arange(len(st.enabled)) != i))
        ox = np.append(st.pos[others, 0], ego.x)
        oz = np.append(st.pos[others, 2], ego.z)
        d2 = (pts[:, 0][:, None] - ox[None, :]) ** 2 + (pts[:, 1][:, None] - oz[None, :]) ** 2
        return bool(d2.min() > (float(st.lat_safe[i]) + 0.5) ** 2)

    def _change_segment(self, i: int, k: int) -> bool:
        """Move the carrot 30 m ahead onto neighbour segment k (the car steers over)."""
        net, st = self.network, self.st
        assert net is not None
        seg, cur = net.segments[k], net.segments[int(st.leg[i])]
        progress = float(st.s[i]) / cur.length if cur.length > 0 else 0.0
        s_new = progress * seg.length + LANE_CHANGE_AHEAD_M
        if seg.length <= LANE_CHANGE_AHEAD_M or s_new > seg.length:
            return False
        self.light_queue[i] = []
        st.light_idx[i] = -1
        self._enter_segment(i, k, s_new, apply_from=False)
        return True

    def _passing_lanes(self, rows: np.ndarray) -> None:
        """OpenDS overtaking: blocked -> passing neighbour if clear; regular neighbour when clear."""
        net, st = self.network, self.st
        if net is None:
            return
        for i in map(int, np.flatnonzero(rows & (st.lane_hold_until <= self.t_s))):
            seg = net.segments[int(st.leg[i])]
            passing, regular = (seg.left, seg.right) if net.right_hand else (seg.right, seg.left)
            if st.blocked[i] and passing >= 0 and self._lane_clear(i, passing):
                self._change_segment(i, passing)
            elif regular >= 0 and self._lane_clear(i, regular):
                self._change_segment(i, regular)

    def _give_way(self, rows: np.ndarray, obs_dist: np.ndarray, clearance: np.ndarray) -> np.ndarray:
        """Segments with `giveWayTo`: hold before the end while prioritised traffic arrives too."""
        net, st = self.network, self.st
        out = np.zeros(len(st.speed), dtype=bool)
        if net is None:
            return out
        on_net = (self.kind == KIND_NET) & st.enabled
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = np.where(st.speed > 0.0, np.maximum(0.0, st.leg_end - st.s) / st.speed, np.inf)
            for i in map(int, np.flatnonzero(rows)):
                prio = net.segments[int(st.leg[i])].give_way
                others = on_net & np.isin(st.leg, prio) & (np.arange(len(on_net)) != i)
                others &= np.maximum(0.0, st.leg_end - st.s) < obs_dist[i]
                out[i] = bool(np.any(np.abs(eta[others] - eta[i]) < clearance[i]))
        return out
