"""A `bc:` agent's observation options in a study: the env its trials run in gets them.

Why: a behaviour clone sees what its dataset's env observed; options such as `road_preview_m`
(the road ahead in the vector observation) change that observation, so the clone keeps them
(`data.bc.CLONE_ENV_OPTIONS`, its `bc.json` `env_kwargs`) and refuses an env without them.
`opends-gym run` makes its env with them; a study does too: a trial's env is the study's task
and condition options plus the clone's (they only shape the observation, not the drive the
table measures). A study that sets one of them to another value is refused in one line.
"""

from __future__ import annotations

import functools
import json
from typing import Any

from ..drivers.bc import SETTINGS, resolve_clone
from ..resources import ResourceNotFound


@functools.lru_cache(maxsize=256)
def _clone_options(arg: str) -> tuple[tuple[str, Any], ...]:
    try:
        folder = resolve_clone(arg)
        settings = json.loads((folder / SETTINGS).read_text(encoding="utf-8"))
    except (ResourceNotFound, OSError, ValueError):
        return ()  # (no readable clone: building the agent says so, in one line)
    kwargs = settings.get("env_kwargs") if isinstance(settings, dict) else None
    if not isinstance(kwargs, dict):
        return ()
    return tuple(sorted((str(k), tuple(v) if isinstance(v, list) else v) for k, v in kwargs.items()))


def clone_options(agent: str) -> dict[str, Any]:
    """The env options the clone of agent spec `agent` was trained with ({} for other agents)."""
    name, _, arg = agent.partition(":")
    return dict(_clone_options(arg)) if name == "bc" and arg else {}


def _same(a: Any, b: Any) -> bool:
    """Option values equal as the env reads them (a YAML list [10, 25] is the clone's (10.0, 25.0))."""
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return bool(a == b)


def conflicting_option(agent: str, env_args: dict[str, Any]) -> tuple[str, Any] | None:
    """(option, the clone's value) where `env_args` set an option of `agent`'s clone otherwise, or None."""
    for key, value in clone_options(agent).items():
        if key in env_args and not _same(env_args[key], value):
            return key, value
    return None


def with_clone_options(agent: str, env_args: dict[str, Any]) -> dict[str, Any]:
    """`env_args` plus the options of `agent`'s clone that they do not set."""
    extra = {k: v for k, v in clone_options(agent).items() if k not in env_args}
    return {**env_args, **extra} if extra else env_args
