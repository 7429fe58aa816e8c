"""`WorldConfig`: how a World simulates (backend, step, traffic, contacts, instruction screens).

Its own module so that the parts a World owns (the trigger core reads `auto_close_instructions`)
can name it without importing the World."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class WorldConfig:
    """How a World simulates. Units in the names; frozen so it can key caches."""

    physics: str = "fast"  # fast | bullet
    dt_s: float = 1.0 / 60.0
    traffic: bool = True
    collision_stops_car: bool = True
    # openInstructionsScreen: close at once (RL); False pauses until Return/Space (human mode)
    auto_close_instructions: bool = True

    def __post_init__(self) -> None:
        # a NaN or zero step never advances time; the bound is EnvConfig's 10 kHz physics_hz
        if not (isinstance(self.dt_s, (int, float)) and math.isfinite(self.dt_s) and 1e-4 <= self.dt_s <= 1.0):
            raise ValueError(f"WorldConfig.dt_s must be a number of seconds in [0.0001, 1], not {self.dt_s!r}")
