"""The shared simulation core: World, physics backends, powertrain, traffic, triggers.

Gymnasium-free by design: envs, the replay and the human mode all drive a `World`.
"""

from .controls import DriverControls
from .events import Event, EventLog
from .world import World, WorldConfig

__all__ = ["DriverControls", "Event", "EventLog", "World", "WorldConfig"]
