"""What the pedals do at a given speed, from the car model: the throttle that holds the
speed, the deceleration of coasting and of a full brake.

Why: a driver following a lead at steady speed holds the accelerator (the engine must
beat the free-wheel drag of OpenDS's `SteeringCar.update`); the foot leaves it only when
more deceleration is needed than coasting gives, and brakes only then. The speed
controllers (`drivers.rule`) use these values as a feed-forward, so their integral does
not have to rebuild the cruising throttle after every brake and a small speed excess is
met by easing the throttle, not by braking. The values are read off the car's own
powertrain (`sim.ego.powertrain.Powertrain`, OpenDS's `PowerTrain` and free-wheel brake),
level road, constant speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..sim.ego.powertrain import Powertrain, gear_rpm
from ..task.model_car import Car

SPEED_STEP_MPS = 2.0
MAX_SPEED_MPS = 50.0
COAST_TOLERANCE_MPS2 = 0.02  # a throttle within this of coasting's deceleration still coasts


def _net_accel(pt: Powertrain, v: float, gas: float, brake: float) -> float:
    """Steady-state acceleration (m/s^2) at speed v with these pedals: drive force less the
    brake and free-wheel force, over the mass (engine at the gear's rpm, no speed change)."""
    if v <= 0.0:
        return 0.0
    gear = pt.best_gear(v)
    pt.state.gear = gear
    pt.state.prev_v_mps = v
    pt.state.rpm = max(gear_rpm(v, pt.ratios[gear - 1]), pt.engine.min_rpm)
    pt.forces(0.01, v, gas, brake)
    drive, resist = pt.forces(0.01, v, gas, brake)
    if drive > 0.0:  # a wheel with engine force does not brake (Bullet's `updateFriction`): the rear two drag
        resist *= 0.5
    return (drive - resist) / pt.mass_kg


GAS = np.linspace(0.0, 1.0, 34)


@dataclass(frozen=True)
class PedalMap:
    """Per speed (every `SPEED_STEP_MPS`), the steady acceleration at each throttle of `GAS`."""

    accel: np.ndarray  # (speeds, len(GAS)) m/s^2, made non-decreasing in the throttle
    brake_mps2: float  # deceleration per unit brake pedal, beyond coasting

    def _row(self, v: float) -> tuple[int, float]:
        x = min(max(v, 0.0), MAX_SPEED_MPS) / SPEED_STEP_MPS
        i = min(int(x), len(self.accel) - 2)
        return i, x - i

    def _throttle(self, i: int, a: float) -> float:
        row = self.accel[i]
        k = int(np.searchsorted(row, row[0] + COAST_TOLERANCE_MPS2))  # the first throttle that beats coasting
        if k >= len(row):
            return 1.0
        lo = max(k - 1, 0)
        if a <= row[lo]:
            return float(GAS[lo])  # coasting: the foot rests on the pedal, at the top of its dead travel
        return float(np.interp(a, row[lo:], GAS[lo:]))

    def throttle_for(self, v_mps: float, accel_mps2: float) -> float:
        """The accelerator giving this acceleration at speed v (for a deceleration up to
        coasting's: the most throttle that still coasts)."""
        i, f = self._row(v_mps)
        return (1.0 - f) * self._throttle(i, accel_mps2) + f * self._throttle(i + 1, accel_mps2)

    def coast_throttle(self, v_mps: float) -> float:
        """The most throttle that still coasts: where a foot rests that eases off without
        lifting (at cruising speeds the engine's power first beats the load well into the
        pedal's travel, OpenDS's `PowerTrain.getPAccel`)."""
        return self.throttle_for(v_mps, -math.inf)

    def hold_throttle(self, v_mps: float) -> float:
        return self.throttle_for(v_mps, 0.0)

    def coast_decel(self, v_mps: float) -> float:
        i, f = self._row(v_mps)
        return float(-((1.0 - f) * self.accel[i, 0] + f * self.accel[i + 1, 0]))


@lru_cache(maxsize=16)
def pedal_map(car: Car, mass_kg: float) -> PedalMap:
    """The car's pedal map (cached per car block and mass: the blocks are frozen)."""
    pt = Powertrain(car, mass_kg)
    speeds = np.arange(0.0, MAX_SPEED_MPS + SPEED_STEP_MPS / 2, SPEED_STEP_MPS)
    acc = np.array([[_net_accel(pt, float(v), float(g), 0.0) for g in GAS] for v in speeds])
    acc = np.maximum.accumulate(acc, axis=1)
    v_ref = 20.0
    full = -_net_accel(pt, v_ref, 0.0, 1.0) + _net_accel(pt, v_ref, 0.0, 0.0)
    return PedalMap(acc, max(full, 1.0))
