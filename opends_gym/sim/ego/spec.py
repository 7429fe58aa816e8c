"""The vehicle protocol both physics backends implement, and the car's dimensions.

Why: `physics="fast"` (numpy/float single-track model) and `physics="bullet"` (pybullet
raycast vehicle) must be interchangeable under the World, the powertrain and every env.
They agree on this small interface: steer angle and forces in, a `BodyState` out.

Frame: OpenDS world metres, Y up. Yaw 0 faces -Z; positive yaw and positive steering
turn left. `u` is the forward speed, `v` the lateral speed (positive to the left), `r`
the yaw rate (positive turning left).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

from ...task.model_car import Car

# Front-wheel angle at full steering input: OpenDS passes its steering value (-1..1) to jME's
# `VehicleControl.steer()`, which takes the wheels' angle in radians (`Car.steer`), so full
# steering is 1 rad. (Its keyboard steers asin(wheelbase / (turningCircle / 2)) = 0.443 rad
# with the defaults 3.0 m and 14 m: `SimulatorActionListener.onAction`.)
MAX_WHEEL_ANGLE_RAD = 1.0


@dataclass(frozen=True)
class VehicleSpec:
    """Geometry, suspension and tyre grip of a car. OpenDS task files give only mass, suspension
    and frictionSlip (Bullet's impulse limit, load x dt x frictionSlip per wheel); the geometry
    is an assumption (the car's asset is not available)."""

    mass_kg: float = 1300.0
    length_m: float = 4.4
    width_m: float = 1.8
    height_m: float = 1.45
    wheelbase_m: float = 2.7
    cog_to_front_m: float = 1.2
    track_m: float = 1.55
    cog_height_m: float = 0.55
    suspension_stiffness: float = 120.0
    suspension_compression: float = 0.2
    suspension_damping: float = 0.3
    friction_slip: float = 50.0

    @property
    def cog_to_rear_m(self) -> float:
        return self.wheelbase_m - self.cog_to_front_m

    @property
    def yaw_inertia(self) -> float:
        return self.mass_kg * self.cog_to_front_m * self.cog_to_rear_m

    @staticmethod
    def from_car(car: Car, mass_kg: float) -> VehicleSpec:
        """The scenario's car block and its model's mass (1300 kg where none is given)."""
        return VehicleSpec(
            mass_kg=mass_kg if mass_kg > 0 else 1300.0,
            suspension_stiffness=car.suspension.stiffness,
            suspension_compression=car.suspension.compression,
            suspension_damping=car.suspension.damping,
            friction_slip=car.wheel.friction_slip,
        )


@dataclass
class BodyState:
    """Pose and velocities of a car, the same for both backends."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0
    u: float = 0.0
    v: float = 0.0
    r: float = 0.0
    steer_rad: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.u, self.v)

    @property
    def forward(self) -> tuple[float, float]:
        """Unit forward vector in the ground plane (x, z)."""
        return (-math.sin(self.yaw), -math.cos(self.yaw))


class VehicleBackend(Protocol):
    """What the ego car needs from a physics backend."""

    spec: VehicleSpec
    state: BodyState

    def reset(self, x: float, y: float, z: float, yaw: float, speed_mps: float) -> None: ...

    def step(self, dt_s: float, steer_rad: float, drive_force_n: float, brake_force_n: float, side_force_n: float = 0.0) -> None: ...

    def stop_at_contact(self, x: float, z: float) -> None:
        """Collision response for obstacles the backend does not simulate itself."""
        ...

    def get_state(self) -> dict[str, Any]: ...

    def set_state(self, state: dict[str, Any]) -> None: ...

    def close(self) -> None: ...
