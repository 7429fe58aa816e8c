"""A read-only picture of the car after a physics step, for everything outside the loop.

Why: the settings-controller server, the CAN feedback channel and the external
visualization run on other threads or at other rates. They must not reach into the
World while it steps; the runner publishes one immutable `VehicleSnapshot` per step and
they read the latest one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class VehicleSnapshot:
    t_s: float = 0.0
    x_m: float = 0.0
    y_m: float = 0.0
    z_m: float = 0.0
    yaw_rad: float = 0.0
    pitch_rad: float = 0.0
    roll_rad: float = 0.0
    speed_kmh: float = 0.0
    yaw_rate_rps: float = 0.0
    accel_long_mps2: float = 0.0
    accel_lat_mps2: float = 0.0
    steering: float = 0.0
    accelerator: float = 0.0
    brake: float = 0.0
    clutch: float = 0.0
    hand_brake: bool = False
    gear: int = 1
    automatic: bool = True
    rpm: float = 0.0
    engine_on: bool = True
    fuel_used_l: float = 0.0
    fuel_left_l: float = 60.0
    l_per_100km: float = 0.0
    odometer_m: float = 0.0
    turn_signal: str = "off"
    cruise_active: bool = False
    autopilot: bool = False
    lane_id: str | None = None
    speed_limit_kmh: float = 0.0
    paused: bool = False
    length_m: float = 4.4
    width_m: float = 1.8
    height_m: float = 1.45
    mass_kg: float = 1300.0
    max_steering_deg: float = 270.0  # settings.xml CANInterface/maxSteeringAngle (steerAngle reports)
    traffic: tuple[tuple[str, float, float, float], ...] = field(default_factory=tuple)  # (id, x, z, speed km/h)

    @property
    def heading_deg(self) -> float:
        """Compass heading 0..360, clockwise, 0 along -Z (yaw 0)."""
        return (-math.degrees(self.yaw_rad)) % 360.0


def snapshot_of(world: Any, prev: VehicleSnapshot | None = None, max_steering_deg: float = 270.0) -> VehicleSnapshot:
    """Read the World once (call between steps, on the simulation thread)."""
    s = world.ego.state
    ego = world.ego
    pt = ego.powertrain.state
    inp = ego.inputs
    spec = ego.spec
    dt = world.dt_s
    accel_long = 0.0
    if prev is not None and world.t_s > prev.t_s:
        accel_long = (s.u * 3.6 - prev.speed_kmh) / 3.6 / max(world.t_s - prev.t_s, dt)
    traffic: tuple[tuple[str, float, float, float], ...] = ()
    tr = world.traffic
    if tr is not None and getattr(tr, "ids", None) is not None:
        try:  # the traffic manager's arrays: ids, positions (N, 3), speed (N,) m/s
            traffic = tuple((str(i), float(p[0]), float(p[2]), float(v) * 3.6) for i, p, v in zip(tr.ids, tr.positions, tr.speed))
        except Exception:  # its shape is not ours to rely on: report no traffic rather than fail
            traffic = ()
    trig = world.triggers
    return VehicleSnapshot(
        t_s=world.t_s,
        x_m=s.x,
        y_m=s.y,
        z_m=s.z,
        yaw_rad=s.yaw,
        pitch_rad=s.pitch,
        roll_rad=s.roll,
        speed_kmh=s.u * 3.6,
        yaw_rate_rps=s.r,
        accel_long_mps2=accel_long,
        accel_lat_mps2=s.u * s.r,
        steering=inp.steering,
        accelerator=inp.accelerator,
        brake=inp.brake,
        clutch=inp.clutch,
        hand_brake=inp.hand_brake,
        gear=pt.gear,
        automatic=pt.automatic,
        rpm=pt.rpm,
        engine_on=pt.engine_on,
        fuel_used_l=pt.fuel_used_l,
        fuel_left_l=pt.fuel_left_l,
        l_per_100km=pt.l_per_100km,
        odometer_m=pt.odometer_m,
        turn_signal=inp.turn_signal,
        cruise_active=ego.cruise_active,
        autopilot=bool(getattr(trig, "autopilot", False)),
        lane_id=world.road.lane_id_at(s.x),
        speed_limit_kmh=world.road.current_limit_mps * 3.6,
        paused=bool(getattr(trig, "paused", False)),
        length_m=spec.length_m,
        width_m=spec.width_m,
        height_m=spec.height_m,
        mass_kg=spec.mass_kg,
        max_steering_deg=max_steering_deg,
        traffic=traffic,
    )
