"""Commands that steer traffic from outside its paths: overrides, lane changes, external control.

Why: the platoon and brake-reaction envs make a lead car brake, slow down or signal; the
trigger actions `changeLaneODCar`/`setODCarTargetLane` ask for lane changes; the
settings-controller's `SetVehicleControl` drives a traffic car by hand. These setters are
mixed into `TrafficManager` (which owns the state they change). Non-finite numbers are
refused with a ValueError naming the argument, so a bad network message never reaches
the simulation.
"""

from __future__ import annotations

import logging
import math
from typing import Any, Protocol

import numpy as np

from ...task.model_traffic import ODVehicle
from ..events import EventLog
from .legs import KIND_NET, KIND_OD, LANE_HOLD_S, LegLogic, LegWorld
from .motion import outputs
from .routes import TURN_CODES

log = logging.getLogger(__name__)


class ControlsWorld(LegWorld, Protocol):
    """What the trigger-facing controls read of their World: the clock and the event log
    (warnings about requests they cannot carry out)."""

    events: EventLog
    t_s: float


class TrafficControls(LegLogic):
    world: ControlsWorld
    objects: list[Any]
    od_map: Any
    is_car: np.ndarray
    _index: dict[str, int]
    brake_light: np.ndarray
    turn_signal: np.ndarray

    # ------------------------------------------------------------------ shared helpers
    def _need(self, obj_id: str) -> int:
        i = self._index.get(obj_id)
        if i is None:
            raise KeyError(f"no traffic object '{obj_id}' (known: {', '.join(self.ids) or 'none'})")
        return i

    def _event_warning(self, source: str, message: str) -> None:
        log.warning(message)
        self.world.events.emit(self.world.t_s, "warning", source, message=message)

    def _start_route(self, i: int, pid: int, speed: float) -> None:
        st = self.st
        length = float(self.paths.length[pid])
        st.pid[i], st.s[i], st.leg[i], st.leg_end[i], st.halted[i] = pid, 0.0, 0, length, False
        st.v_leg[i], st.v_next[i] = speed, 0.0
        x, _, z, _ = self.paths.point(pid, length)
        st.end_xz[i] = (x, z)
        self._place_car(i)

    def _refresh_outputs(self) -> None:
        """`brake_light` and `turn_signal` (updated in place) from the overrides, paths and braking."""
        outputs(self.st.i, self.st.b, self.brake_light, self.turn_signal)

    # ------------------------------------------------------------------ commands
    def request_lane_change(self, obj_id: str, direction: int, target_lane: int | None = None) -> bool:
        """To the left (-1) / right (+1) neighbour segment, or an OpenDRIVE lane; False if impossible.

        On the road network the car then keeps that lane for LANE_HOLD_S before OpenDS's own
        rule (back to the regular lane when it is clear) applies again.
        """
        i = self._need(obj_id)
        st = self.st
        ok = False
        if self.kind[i] == KIND_NET and self.network is not None and target_lane is None and direction in (-1, 1):
            seg = self.network.segments[int(st.leg[i])]
            k = seg.left if direction < 0 else seg.right
            ok = k >= 0 and self._change_segment(i, k)
            if ok:
                st.lane_hold_until[i] = self.t_s + LANE_HOLD_S
        elif self.kind[i] == KIND_OD:
            ok = self._od_lane_change(i, direction, target_lane)
        if not ok:
            self._event_warning(obj_id, f"lane change of '{obj_id}' not possible here (direction {direction}, lane {target_lane})")
        return ok

    def _od_lane_change(self, i: int, direction: int, target_lane: int | None) -> bool:
        x, z = float(self.st.pos[i, 0]), float(self.st.pos[i, 2])
        here = self.od_map.locate(x, z) if self.od_map is not None else None
        if here is None:
            return False
        road, lane, s = here
        if target_lane is None:  # negative lanes drive towards +s: their left is lane + 1
            new = lane + (1 if lane < 0 else -1) * (1 if direction < 0 else -1)
        else:
            new = int(target_lane)
        if new == 0 or (new > 0) != (lane > 0):
            return False
        o = self.objects[i]
        assert isinstance(o, ODVehicle)
        try:
            ahead = s + (20.0 if lane < 0 else -20.0)  # join the new lane 20 m on, in its driving direction
            pts = np.asarray(self.od_map.route(road, new, ahead, o.target_road_id, None, o.target_s_m, o.preferred_connections))
        except Exception as e:  # an impossible route is refused, not fatal
            log.warning("lane change of '%s' refused: %s", o.id, e)
            return False
        if len(pts) < 2:
            return False
        y = float(self.st.pos[i, 1])
        pid = self.paths.add(np.column_stack([pts[:, 0], np.full(len(pts), y), pts[:, 1]]))
        speed = float(self.st.v_leg[i])
        pos, yaw = self.st.pos[i].copy(), float(self.st.yaw[i])
        self._start_route(i, pid, speed)
        self.st.pos[i], self.st.yaw[i] = pos, yaw  # the car steers over; only its carrot jumped
        return True

    def set_speed_override(self, obj_id: str, target_mps: float | None, decel_mps2: float | None = None) -> None:
        """Drive at `target_mps` instead of the path speed (None: back to the path); with decel, brake at it."""
        i = self._need(obj_id)
        target = _finite("target_mps", target_mps)
        self.st.ov_speed[i] = np.nan if target is None else max(0.0, target)
        decel = _finite("decel_mps2", decel_mps2)
        self.st.ov_decel[i] = np.nan if decel is None or target is None else abs(decel)

    def set_speed(self, obj_id: str, speed_mps: float) -> None:
        """Set an object's current speed at once (scenario setup, e.g. a platoon already moving)."""
        self.st.speed[self._need(obj_id)] = max(0.0, _finite("speed_mps", speed_mps) or 0.0)

    def set_brake_light(self, obj_id: str, on: bool | None) -> None:
        self.st.ov_brake[self._need(obj_id)] = -1 if on is None else int(bool(on))
        self._refresh_outputs()

    def set_turn_signal(self, obj_id: str, signal: str | None) -> None:
        i = self._need(obj_id)
        if signal is not None and signal not in TURN_CODES:
            raise ValueError(f"unknown turn signal '{signal}' (use left, right, both, off or None)")
        self.st.ov_turn[i] = -1 if signal is None else TURN_CODES[signal]
        self._refresh_outputs()

    def set_safety_distance(
        self, obj_id: str, forward_m: float | None = None, lateral_m: float | None = None, speed_dependent: bool | None = None
    ) -> None:
        """OpenDS TrafficCar's min forward (8 m) / lateral (2 m) safety distances and 0.5 v[km/h] rule."""
        i = self._need(obj_id)
        if forward_m is not None:
            self.st.min_fwd[i] = max(0.0, _finite("forward_m", forward_m) or 0.0)
        if lateral_m is not None:
            self.st.lat_safe[i] = max(0.0, _finite("lateral_m", lateral_m) or 0.0)
        if speed_dependent is not None:
            self.st.speed_dep[i] = bool(speed_dependent)

    def set_external_control(self, obj_id: str, steering: float, accelerator: float, brake: float) -> None:
        """Settings-controller `SetVehicleControl`: the car leaves its path and obeys these inputs."""
        i = self._need(obj_id)
        if not self.is_car[i]:
            raise ValueError(f"'{obj_id}' is a pedestrian, not a vehicle")
        steer, gas, pedal = (_finite(n, v) or 0.0 for n, v in (("steering", steering), ("accelerator", accelerator), ("brake", brake)))
        self.st.ext[i] = True
        self.st.ext_cmd[i] = (min(1.0, max(-1.0, steer)), min(1.0, max(0.0, gas)), min(1.0, max(0.0, pedal)))

    def release_external_control(self, obj_id: str) -> None:
        """Back to following the path (the carrot waits where it was left)."""
        i = self._need(obj_id)
        self.st.ext[i] = False
        self.st.ext_cmd[i] = 0.0


def _finite(name: str, value: float | None) -> float | None:
    if value is None:
        return None
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v
