"""Trigger core (interaction.xml at run time). TRANSITIONAL: replaced by the full core."""

from __future__ import annotations

from typing import Any


class TriggerCore:
    def __init__(self, world: Any) -> None:
        self.world = world
        self.paused = False

    def reset(self) -> None:
        self.paused = False

    def before_physics(self, controls: Any) -> None:
        return None

    def after_physics(self, controls: Any) -> None:
        return None

    def get_state(self) -> Any:
        return self.paused

    def set_state(self, state: Any) -> None:
        self.paused = state
