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
    show_all = not (args.envs or args.tasks or args.policies or args.configs)
    if args.tasks or show_all:
        print("bundled tasks:")
        for name in bundled_task_names():
            print(f"  {name}")
    if args.envs or show_all:
        print("environments:")
        for env_id in registered_env_ids():
            print(f"  {env_id}")
    if args.policies or show_all:
        print("policies (--agent ALGORITHM:NAME):")
        for name in policy_names():
            print(f"  {name}")
    if args.configs or show_all:
        print("training configs (opends-gym train NAME):")
        for name in config_names():
            print(f"  {name}")
    return 0
