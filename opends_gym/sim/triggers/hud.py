"""What the trigger core asks the driver's screen to show (messages, pictures, frames).

Why: envs render it, the human viewer draws it and the recorder stores it; keeping it as
plain data in the core means all three see the same thing at the same simulation time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass
class HudState:
    message: str = ""
    message_until_s: float = 0.0
    instruction_screen: str | None = None
    warning_interval_s: float = 0.0
    warning_until_s: float = 0.0
    pictures: dict[str, bool] = field(default_factory=dict)
    gauge: dict[str, str] = field(default_factory=dict)
    presentation: dict[str, Any] | None = None

    def message_at(self, t_s: float) -> str:
        """The on-screen message at time t (empty when it has expired)."""
        return self.message if t_s < self.message_until_s else ""

    def warning_frame_on(self, t_s: float) -> bool:
        """Whether the flashing warning frame is lit at time t."""
        if t_s >= self.warning_until_s or self.warning_interval_s <= 0.0:
            return False
        return math.floor(t_s / self.warning_interval_s) % 2 == 0
