"""`WorldConfig`: how a World simulates (backend, step, traffic, contacts, instruction screens).

Its own module so that the parts a World owns (the trigger core reads `auto_close_instructions`)
can name it without importing the World."""

from __future__ import annotations

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
