"""The structured event log: the single source for `info`, the recorder and the viewer.

Why: triggers fired, actions run, messages shown, sounds played and reactions scored are
all written here once, in simulation time; everyone else reads from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Event:
    """One thing that happened at simulation time `t_s`."""

    t_s: float
    kind: str  # trigger | action | message | sound | reaction | collision | recording | ...
    source: str  # trigger id, action name, timer id, object id...
    params: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"t_s": self.t_s, "kind": self.kind, "source": self.source, "params": dict(self.params)}


class EventLog:
    """Append-only list of events with a read cursor per consumer."""

    def __init__(self) -> None:
        self._events: list[Event] = []

    def emit(self, t_s: float, kind: str, source: str, /, **params: Any) -> Event:
        ev = Event(t_s, kind, source, params)
        self._events.append(ev)
        return ev

    def __len__(self) -> int:
        return len(self._events)

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self._events)

    def since(self, index: int) -> list[Event]:
        """Events appended after position `index` (pass the previous len())."""
        return self._events[index:]

    def of_kind(self, kind: str) -> list[Event]:
        return [e for e in self._events if e.kind == kind]

    def clear(self) -> None:
        self._events.clear()

    def get_state(self) -> list[Event]:
        return list(self._events)

    def set_state(self, events: list[Event]) -> None:
        self._events = list(events)
