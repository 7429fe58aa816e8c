"""The shared trigger core: conditions, actions, reaction timers (see `core`)."""

from .actions import BUILTIN_HANDLERS
from .core import TriggerCore, TriggerWorld
from .hud import HudState
from .reactions import CORRECT, FAILURE, MISSED, ReactionResult


def make_trigger_core(world: TriggerWorld) -> TriggerCore:
    """A trigger core for `world` that carries out OpenDS's built-in actions."""
    return TriggerCore(world, BUILTIN_HANDLERS)


__all__ = ["CORRECT", "FAILURE", "MISSED", "HudState", "ReactionResult", "TriggerCore", "TriggerWorld", "make_trigger_core"]
