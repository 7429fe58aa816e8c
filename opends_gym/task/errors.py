"""Errors and warnings of the task loader.

Why: a researcher with a broken driving task needs to know *which file, which line and
which element* is wrong. Every problem the loader finds is either a `TaskError` (the
task cannot be used) or a `TaskWarning` (OpenDS would tolerate it, and so do we).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

log = logging.getLogger("opends_gym.task")


def _where(file: str | Path | None, line: int | None, element: str | None) -> str:
    parts = []
    if file is not None:
        parts.append(str(file) + (f":{line}" if line else ""))
    elif line:
        parts.append(f"line {line}")
    if element:
        parts.append(f"<{element}>")
    return " ".join(parts)


class TaskError(Exception):
    """A driving task that cannot be loaded; the message names file, line and element."""

    def __init__(
        self,
        message: str,
        file: str | Path | None = None,
        line: int | None = None,
        element: str | None = None,
    ) -> None:
        self.file = str(file) if file is not None else None
        self.line = line
        self.element = element
        self.reason = message
        where = _where(file, line, element)
        super().__init__(f"{where}: {message}" if where else message)


@dataclass(frozen=True)
class TaskWarning:
    """Something OpenDS tolerates (unknown action, missing asset...): logged, not fatal."""

    message: str
    file: str | None = None
    line: int | None = None
    element: str | None = None

    def __str__(self) -> str:
        where = _where(self.file, self.line, self.element)
        return f"{where}: {self.message}" if where else self.message


@dataclass
class Diagnostics:
    """Collects warnings while one task loads (one instance per `load_task` call)."""

    warnings: list[TaskWarning] = field(default_factory=list)
    _seen: set[str] = field(default_factory=set)

    def warn(
        self,
        message: str,
        file: str | Path | None = None,
        line: int | None = None,
        element: str | None = None,
        once_key: str | None = None,
        log_level: int = logging.WARNING,
    ) -> None:
        """Record a warning; with `once_key`, only the first of its kind is kept.

        Every warning lands in `DrivingTask.warnings`; `log_level` says how loudly it is
        also logged (missing 3D models and sounds are routine, so they log at INFO), the
        first time this process meets it (later loads of the same file log it at DEBUG)."""
        if once_key is not None:
            if once_key in self._seen:
                return
            self._seen.add(once_key)
        w = TaskWarning(message, str(file) if file is not None else None, line, element)
        self.warnings.append(w)
        if w in _LOGGED:  # the same file is loaded again (every make): once per process is enough
            log.debug("%s", w)
            return
        _LOGGED.add(w)
        log.log(log_level, "%s", w)


# warnings already logged in this process (file, line, element, message): each goes to the
# log once however often its task is loaded; every load still lists it in `DrivingTask.warnings`
_LOGGED: set[TaskWarning] = set()
