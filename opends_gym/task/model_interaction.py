"""interaction.xml: activities (sequences of actions) and the triggers that run them."""

from __future__ import annotations

from dataclasses import dataclass

from .bind import FLOAT, INT, STR, Custom, Struct, attr, elem, elems, source_line
from .conditions import ConditionSet, read_conditions, write_conditions


@dataclass(frozen=True)
class Parameter:
    name: str = attr("name", required=True)
    value: str = attr("value", STR, "")
    line: int = source_line()


@dataclass(frozen=True)
class Action:
    """One call of an OpenDS interaction method; `delay_s` in simulation seconds.

    `repeat` caps how often it may run over the whole drive (0 = unlimited). Parameter
    values stay as written; `actions_catalog` types them (`typed_args`).
    """

    name: str = attr("id", required=True)
    delay_s: float = attr("delay", FLOAT, 0.0)
    repeat: int = attr("repeat", INT, 0)
    params: tuple[Parameter, ...] = elems(".", ("parameter", Struct(Parameter)))
    line: int = source_line()

    def param(self, name: str, default: str | None = None) -> str | None:
        return next((p.value for p in self.params if p.name == name), default)


@dataclass(frozen=True)
class Activity:
    """A named list of actions; inside a trigger it may instead `ref` a declared one."""

    id: str = attr("id", STR, "")
    ref: str = attr("ref", STR, "")
    actions: tuple[Action, ...] = elems(".", ("action", Struct(Action)))
    line: int = source_line()


CONDITIONS = Custom(read_conditions, write_conditions)


@dataclass(frozen=True)
class Trigger:
    id: str = attr("id", STR, "")
    priority: int = attr("priority", INT, 1)
    activities: tuple[Activity, ...] = elems("activities", ("activity", Struct(Activity)))
    condition: ConditionSet = elem("condition", CONDITIONS, required=True)
    line: int = source_line()


@dataclass(frozen=True)
class Interaction:
    activities: tuple[Activity, ...] = elems("activities", ("activity", Struct(Activity)))
    triggers: tuple[Trigger, ...] = elems("triggers", ("trigger", Struct(Trigger)))

    def activity(self, activity_id: str) -> Activity | None:
        return next((a for a in self.activities if a.id == activity_id), None)

    def resolved_activities(self, trigger: Trigger) -> tuple[Activity, ...]:
        """The trigger's activities with `ref`s replaced by the declared activity."""
        out = []
        for a in trigger.activities:
            target = self.activity(a.ref) if a.ref and not a.actions else a
            if target is not None:
                out.append(target)
        return tuple(out)

    def all_actions(self) -> tuple[Action, ...]:
        acts: list[Action] = []
        for a in self.activities:
            acts.extend(a.actions)
        for t in self.triggers:
            for a in t.activities:
                acts.extend(a.actions)
        return tuple(acts)
