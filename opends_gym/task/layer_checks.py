"""Checks of layer files the task layer cannot read itself (the OpenDRIVE road network).

Why: `road.xodr` is read by `sim.opendrive`, a layer above `task`; without a check here a
broken file passed `load_task` and `validate` and failed only at `gym.make`. The reader
registers itself on import (importing `opends_gym` imports it), and `load_task` runs it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

_CHECKS: dict[str, Callable[[Path], object]] = {}


def register(key: str, check: Callable[[Path], object]) -> None:
    """Make `load_task` call `check(path)` on the file the entry names under `key`; it raises TaskError."""
    _CHECKS[key] = check


def run(key: str, path: Path) -> None:
    check = _CHECKS.get(key)
    if check is not None:
        check(path)
