"""What the CLI drives: an env id or a task, and `--env-arg KEY=VALUE` options typed per env.

Why: a misspelt env id must not be taken for a task path, and `--env-arg polcy_hz=20` or
`policy_hz=fast` must be one line naming the option that was meant, before any env is built.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

from ..envs.registration import lookup_env_id, register_envs
from ..errors import UserError
from ..hints import closest

# `Namespace/Name-vN` or `Name-vN`: Gymnasium's id shape, never a task path
ENV_ID_SHAPE = re.compile(r"^(?:[\w.-]+/)?[A-Za-z][\w.-]*-v\d+$")
DEFAULT_TASK_ENV = "OpenDS/DrivingTask-v0"


def registered_ids() -> list[str]:
    register_envs()
    return sorted(k for k in gym.registry if k.startswith("OpenDS/"))


def _id_aliases() -> dict[str, str]:
    """Every way to name a registered id (full id, `Name-v0`, `Name`) -> the full id."""
    aliases: dict[str, str] = {}
    for env_id in registered_ids():
        short = env_id.split("/", 1)[1]
        for alias in (env_id, short, short.rsplit("-v", 1)[0]):
            aliases.setdefault(alias, env_id)
    return aliases


def _suggest(target: str, aliases: dict[str, str], extra: Sequence[str] = ()) -> str:
    """`; did you mean X?` over env ids (reported in full) and `extra` names."""
    name = target.split("/", 1)[1] if "/" in target else target
    match = closest(target, [*aliases, *extra]) or closest(name, [*aliases, *extra])
    if match is None:
        return ""
    return f"; did you mean {aliases.get(match, match)}?"


def resolve_env_id(target: str) -> tuple[str, dict[str, Any]]:
    """`envs.registration.resolve_env_id` for the CLI: a UserError with a did-you-mean where the
    target is neither a registered id nor an existing task (never a misspelt id taken for a path)."""
    from ..task.bundled import bundled_task_names

    env_id = lookup_env_id(target)
    if env_id is not None:
        return env_id, {}
    aliases = _id_aliases()
    exists = Path(target).exists()
    if ENV_ID_SHAPE.match(target) and not exists:
        raise UserError(f"unknown env id '{target}'{_suggest(target, aliases)} (known: {', '.join(registered_ids())})")
    bundled = bundled_task_names()
    if not exists and target.lower() not in (n.lower() for n in bundled):
        raise UserError(
            f"'{target}' is neither an env id nor a task (no such file or folder, no bundled task of that name)"
            f"{_suggest(target, aliases, bundled)}"
        )
    return DEFAULT_TASK_ENV, {"task": target}


def config_class(env_id: str) -> type[Any] | None:
    """The env's config dataclass (`OpenDSEnv.config_class`), without building the env."""
    entry = gym.spec(env_id).entry_point
    if not isinstance(entry, str):
        return getattr(entry, "config_class", None)
    module, _, name = entry.partition(":")
    return getattr(getattr(importlib.import_module(module), name), "config_class", None)


def _coerce(key: str, text: str, kind: str) -> Any:
    """`text` as the field's declared type (the dataclass annotation's name)."""
    where = f"--env-arg {key}={text}"
    if kind == "bool":
        if text.lower() in ("true", "1", "yes", "on"):
            return True
        if text.lower() in ("false", "0", "no", "off"):
            return False
        raise UserError(f"{where}: expected true or false")
    if kind == "int":
        try:
            return int(text)
        except ValueError:
            raise UserError(f"{where}: expected an integer") from None
    if kind == "float":
        try:
            return float(text)
        except ValueError:
            raise UserError(f"{where}: expected a number") from None
    if kind == "str":
        return text
    if kind.startswith("tuple[float"):  # e.g. road_preview_m=10,25,50
        try:
            return tuple(float(v) for v in text.split(",") if v.strip())
        except ValueError:
            raise UserError(f"{where}: expected numbers separated by commas, such as 10,25,50") from None
    if kind.startswith("dict"):
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            value = None
        if not isinstance(value, dict):
            raise UserError(f'{where}: expected a JSON object such as {{"render_view": "driver_view"}}')
        return value
    return parse_value(text)


def parse_value(text: str) -> Any:
    """Untyped `KEY=VALUE` value: int, float, true/false or the text itself."""
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def parse_env_args(items: list[str], env_id: str) -> dict[str, Any]:
    """`KEY=VALUE` items -> kwargs of `env_id`, typed by its config dataclass."""
    cls = config_class(env_id)
    fields = {f.name: str(f.type) for f in dataclasses.fields(cls)} if cls is not None else {}
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UserError(f"--env-arg {item!r}: expected KEY=VALUE")
        if fields and key not in fields:
            match = closest(key, fields)
            hint = f"; did you mean {match}?" if match else ""
            raise UserError(f"--env-arg {key}: not an option of {env_id}{hint} (options: {', '.join(sorted(fields))})")
        out[key] = _coerce(key, text, fields[key]) if fields else parse_value(text)
    return out
