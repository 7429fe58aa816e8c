"""The README's action-space statements are the spaces the envs have (and the docstrings' too)."""

from __future__ import annotations

import re
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)

from .conftest import ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")
IDS = sorted(k for k in gym.registry if k.startswith("OpenDS/"))
SPACE = re.compile(r"(Box\((-?[\d.]+|-?inf), (-?[\d.]+|inf), \(([\d, ]+)\)\)|Discrete\((\d+)\))")


def matches(statement: str, space: Any) -> bool:
    """`Box(-1, 1, (6,))` or `Discrete(5)` as written in the docs, against the space itself."""
    m = SPACE.fullmatch(statement.strip())
    assert m, f"not a space statement: {statement!r}"
    if m.group(5) is not None:
        return isinstance(space, gym.spaces.Discrete) and int(space.n) == int(m.group(5))
    shape = tuple(int(v) for v in m.group(4).split(",") if v.strip())
    return (
        isinstance(space, gym.spaces.Box)
        and space.shape == shape
        and bool(np.all(space.low == float(m.group(2))))
        and bool(np.all(space.high == float(m.group(3))))
    )


def env_table() -> dict[str, str]:
    """README `## Environments` table: env id -> its 'default action space' cell."""
    lines = README.split("## Environments", 1)[1].splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("| id |"))
    cols = [c.strip() for c in lines[header].strip("|").split("|")]
    col = cols.index("default action space")
    rows: dict[str, str] = {}
    for line in lines[header + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip().strip("`") for c in line.strip("|").split("|")]
        rows[cells[0]] = cells[col]
    return rows


def action_options() -> dict[str, str]:
    """The README's `action` bullet: option name -> the space it states (`name` (`Space`: ...))."""
    bullet = README.split("- `action`:", 1)[1].split("\n- ", 1)[0]
    found = dict(re.findall(r"`(\w+)` \(`([^`]+)`", bullet))
    assert {"continuous", "continuous_buttons", "discrete"} <= set(found)
    return found


def test_the_table_lists_every_registered_env() -> None:
    assert sorted(env_table()) == IDS


@pytest.mark.parametrize("env_id", IDS)
def test_default_action_space_is_the_readme_s(env_id: str) -> None:
    env = gym.make(env_id)
    try:
        assert matches(env_table()[env_id], env.action_space), f"README says {env_table()[env_id]}, {env_id} has {env.action_space}"
        doc = type(env.unwrapped).__doc__ or ""
        stated = re.search(r"Default `\w+`: (Box\([^)]*\)\))", doc)  # the env's manual, where it states the space
        if stated:
            assert matches(stated.group(1), env.action_space), f"{env_id} docstring says {stated.group(1)}"
    finally:
        env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_each_action_option_gives_the_readme_s_space(env_id: str) -> None:
    for name, statement in action_options().items():
        env = gym.make(env_id, action=name)
        try:
            assert matches(statement, env.action_space), f"README says action={name} is {statement}; {env_id} has {env.action_space}"
        finally:
            env.close()


def test_a_wrong_statement_is_caught() -> None:
    assert not matches("Box(-1, 1, (2,))", gym.spaces.Box(-1.0, 1.0, shape=(6,)))
    assert not matches("Discrete(5)", gym.spaces.Box(-1.0, 1.0, shape=(2,)))
