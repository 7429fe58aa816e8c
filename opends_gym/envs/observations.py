"""Observation types, chosen by name: kinematics (default), rays, topdown, driver_view.

Why: a cheap vector observation trains fastest; images are for perception research.
Each type is a small class with `space()` and `observe()`, registered in
`OBSERVATION_TYPES`. Vector observations are float32 in SI units (documented per slot in
`names`), so SB3 accepts them; wrap with `NormalizeObservation` to normalise.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from ..sim.guide import RoadGuide, wrap_angle
from ..sim.traffic.queries import nearest_slots
from ..sim.world import World

StimulusFn = Callable[[], Sequence[float]]

EGO_NAMES = (
    "speed_mps",
    "heading_error_rad",
    "lane_offset_m",
    "lateral_position_m",
    "lane_index",
    "steering",
    "yaw_rate_radps",
)
PREVIEW_NAMES = ("road_heading_{d}m_rad", "road_left_{d}m_m")  # per distance of `road_preview_m`
VEHICLE_NAMES = ("present", "ahead_m", "left_m", "rel_speed_mps", "brake_light", "turn_signal")


class ObservationType:
    name = ""

    def __init__(self, world: World, guide: RoadGuide, config: Any, stimulus: StimulusFn, stimulus_names: Sequence[str]) -> None:
        self.world = world
        self.guide = guide
        self.config = config
        self.stimulus = stimulus
        self.stimulus_names = tuple(stimulus_names)

    def space(self) -> gym.spaces.Space[Any]:
        raise NotImplementedError

    def observe(self) -> np.ndarray:
        raise NotImplementedError

    def ego_features(self) -> list[float]:
        w = self.world
        s = w.ego.state
        p = self.guide.locate(s.x, s.z)
        lane = p.lane_index
        offset = (
            p.lateral_m - self.guide.lane_laterals_m[lane]
            if lane >= 0
            else p.lateral_m - self.guide.lane_laterals_m[self.guide.nearest_lane(p.lateral_m)]
        )
        return [s.u, wrap_angle(s.yaw - p.heading_rad), offset, p.lateral_m, float(lane), w.ego.inputs.steering, s.r]

    def preview_names(self) -> tuple[str, ...]:
        """The road preview's slots: per distance d of `road_preview_m`, PREVIEW_NAMES."""
        return tuple(n.format(d=f"{d:g}") for d in self.config.road_preview_m for n in PREVIEW_NAMES)

    def preview_features(self) -> list[float]:
        """The road d m ahead along the reference line (from the car's foot point): its heading
        relative to the car's (rad, + the road turns left) and that point's position across the
        car's frame (m, + left). The far point of the two-point model of steering (Salvucci &
        Gray 2004, "A two-point visual control model of steering", Perception 33): drivers steer
        into a bend by the road ahead before the heading error or lane offset builds up."""
        s = self.world.ego.state
        s_m = self.guide.locate(s.x, s.z).s_m
        lx, lz = -math.cos(s.yaw), math.sin(s.yaw)  # the car's left (forward is (-sin, -cos))
        out = []
        for d in self.config.road_preview_m:
            x, z, heading = self.guide.point_at(s_m + d)
            out += [wrap_angle(heading - s.yaw), (x - s.x) * lx + (z - s.z) * lz]
        return out


class KinematicsObservation(ObservationType):
    """Ego state, the K nearest traffic objects (ego frame) and the task's stimuli.

    Layout: EGO_NAMES, then K x VEHICLE_NAMES (nearest first, ties to the object listed
    first; `ahead_m`/`left_m` in the ego frame, `rel_speed_mps` along the ego's heading;
    turn_signal 0 off, 1 left, 2 right, 3 both; empty slots are zeros), then the env's
    stimulus features, then the road preview (`road_preview_m`, none by default).
    """

    name = "kinematics"

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.k = int(self.config.nearby_vehicles)
        self._preview = self.preview_names()
        self.size = len(EGO_NAMES) + self.k * len(VEHICLE_NAMES) + len(self.stimulus_names) + len(self._preview)
        vehicles = tuple(f"vehicle{i}_{n}" for i in range(self.k) for n in VEHICLE_NAMES)
        self.names = EGO_NAMES + vehicles + self.stimulus_names + self._preview
        self._ego = np.zeros((4, 1))  # (x, z, yaw, speed) for `nearest_slots`

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-np.inf, np.inf, shape=(self.size,), dtype=np.float32)

    def observe(self) -> np.ndarray:
        out = np.zeros((1, self.size), dtype=np.float32)
        out[0, : len(EGO_NAMES)] = self.ego_features()
        traffic = self.world.traffic
        if self.k and traffic is not None and len(traffic.ids):
            s = self.world.ego.state
            ego = self._ego
            ego[0, 0], ego[1, 0], ego[2, 0], ego[3, 0] = s.x, s.z, s.yaw, s.u
            n = len(traffic.ids)
            nearest_slots(traffic.positions, traffic.yaw, traffic.speed, traffic.enabled, traffic.brake_light, traffic.turn_signal, n, ego,
                          self.k, out, len(EGO_NAMES))  # fmt: skip
        at = len(EGO_NAMES) + self.k * len(VEHICLE_NAMES)
        if self.stimulus_names:
            out[0, at : at + len(self.stimulus_names)] = self.stimulus()
        if self._preview:
            out[0, at + len(self.stimulus_names) :] = self.preview_features()
        return out[0]


class RaysObservation(ObservationType):
    """Ego features (speed, heading error, lane offset) then N range readings (m).

    Rays fan out evenly around the car from straight ahead, counter-clockwise (left
    first); each reads the distance to the nearest traffic object, obstacle or outer
    lane edge, capped at `ray_range_m`.
    """

    name = "rays"

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.n = int(self.config.rays)
        self.range = float(self.config.ray_range_m)
        angles = np.linspace(0.0, 2.0 * math.pi, self.n, endpoint=False)
        self._angles = angles
        rays = tuple(f"ray{i}_m" for i in range(self.n))
        self.names = ("speed_mps", "heading_error_rad", "lane_offset_m") + rays + self.stimulus_names + self.preview_names()

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(-np.inf, np.inf, shape=(len(self.names),), dtype=np.float32)

    def _boxes(self) -> list[tuple[float, float, float, float, float]]:
        """(cx, cz, yaw, hx, hz) of everything a ray can hit near the car."""
        s = self.world.ego.state
        out = []
        traffic = self.world.traffic
        if traffic is not None and len(traffic.ids):
            d = np.hypot(traffic.positions[:, 0] - s.x, traffic.positions[:, 2] - s.z)
            for j in np.flatnonzero((d < self.range + 10.0) & traffic.enabled):
                hx, hz = traffic.half_extents[j]
                out.append((float(traffic.positions[j, 0]), float(traffic.positions[j, 2]), float(traffic.yaw[j]), float(hx), float(hz)))
        for o in self.world.objects.near(s.x, s.z, self.range):
            if o.collidable:
                hx, _, hz = o.half
                out.append((o.position[0], o.position[2], o.yaw, hx, hz))
        return out

    def observe(self) -> np.ndarray:
        s = self.world.ego.state
        ego = self.ego_features()
        dirs = s.yaw + self._angles
        ux, uz = -np.sin(dirs), -np.cos(dirs)
        dist = np.full(self.n, self.range)
        for cx, cz, yaw, hx, hz in self._boxes():
            # ray vs oriented box (slab method in the box frame)
            c, sn = math.cos(yaw), math.sin(yaw)
            ox, oz = s.x - cx, s.z - cz
            lo_x, lo_z = ox * c - oz * sn, ox * sn + oz * c
            dx, dz = ux * c - uz * sn, ux * sn + uz * c
            with np.errstate(divide="ignore", invalid="ignore"):
                t1x, t2x = (-hx - lo_x) / dx, (hx - lo_x) / dx
                t1z, t2z = (-hz - lo_z) / dz, (hz - lo_z) / dz
            tmin = np.maximum(np.minimum(t1x, t2x), np.minimum(t1z, t2z))
            tmax = np.minimum(np.maximum(t1x, t2x), np.maximum(t1z, t2z))
            hit = (tmax >= np.maximum(tmin, 0.0)) & np.isfinite(tmin)
            dist = np.where(hit, np.minimum(dist, np.maximum(tmin, 0.0)), dist)
        lanes = self.world.road.lanes
        if lanes:
            with np.errstate(divide="ignore", invalid="ignore"):
                for edge in (lanes[0].x_min, lanes[-1].x_max):
                    t = (edge - s.x) / ux
                    dist = np.where((t > 0) & np.isfinite(t), np.minimum(dist, t), dist)
        preview = self.preview_features() if self.config.road_preview_m else []
        out = np.asarray(ego[:3] + list(dist) + list(self.stimulus() if self.stimulus_names else ()) + preview, dtype=np.float32)
        return out


class ImageObservation(ObservationType):
    """An RGB uint8 image (H, W, 3) from a renderer; works without a display."""

    renderer_kind = ""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        from ..render import make_renderer

        self.renderer = make_renderer(self.renderer_kind, self.world)
        self.shape = (int(self.config.image_height), int(self.config.image_width), 3)

    def space(self) -> gym.spaces.Box:
        return gym.spaces.Box(0, 255, shape=self.shape, dtype=np.uint8)

    def observe(self) -> np.ndarray:
        return self.renderer.render(self.shape[1], self.shape[0])


class TopDownObservation(ImageObservation):
    name = "topdown"
    renderer_kind = "topdown"


class DriverViewObservation(ImageObservation):
    name = "driver_view"
    renderer_kind = "driver_view"


OBSERVATION_TYPES: dict[str, type[ObservationType]] = {
    t.name: t for t in (KinematicsObservation, RaysObservation, TopDownObservation, DriverViewObservation)
}


def make_observation_type(
    name: str, world: World, guide: RoadGuide, config: Any, stimulus: StimulusFn, stimulus_names: Sequence[str]
) -> ObservationType:
    try:
        cls = OBSERVATION_TYPES[name]
    except KeyError:
        raise ValueError(f"unknown observation type {name!r}; choose from {', '.join(OBSERVATION_TYPES)}") from None
    return cls(world, guide, config, stimulus, stimulus_names)
