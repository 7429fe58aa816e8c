"""The shared trigger core: conditions, actions, reaction timers (see `core`)."""

from .core import TriggerCore
from .hud import HudState
from .reactions import CORRECT, FAILURE, MISSED, ReactionResult

__all__ = ["CORRECT", "FAILURE", "MISSED", "HudState", "ReactionResult", "TriggerCore"]
