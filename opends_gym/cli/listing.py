"""`opends-gym list`: bundled tasks, registered environment ids, bundled policies and training configs."""

from __future__ import annotations

import argparse

from ..resources import config_names, policy_names
from ..task.bundled import bundled_task_names


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--envs", action="store_true", help="only environment ids")
    p.add_argument("--tasks", action="store_true", help="only bundled tasks")
    p.add_argument("--policies", action="store_true", help="only bundled policies (--agent ppo:NAME)")
    p.add_argument("--configs", action="store_true", help="only bundled training configs (opends-gym train NAME)")


def registered_env_ids() -> list[str]:
    """Ids registered by opends_gym (importing it registers them)."""
    try:
        import gymnasium

        from ..envs.registration import register_envs

        register_envs()
    except ImportError:
        return []
    return sorted(k for k in gymnasium.registry if k.startswith("OpenDS/"))


def run(args: argparse.Namespace) -> int:
    sections = (
        (args.tasks, "bundled tasks:", bundled_task_names),
        (args.envs, "environments:", registered_env_ids),
        (args.policies, "policies (--agent ALGORITHM:NAME):", policy_names),
        (args.configs, "training configs (opends-gym train NAME):", config_names),
    )
    show_all = not any(asked for asked, _, _ in sections)
    for asked, title, names in sections:
        if asked or show_all:
            print(title)
            for name in names():
                print(f"  {name}")
    return 0
