"""`opends-gym`: one entry point, one module per sub-command.

Why: sub-commands register themselves from their own modules (`add_parser` + `run`), so
adding one touches no if/elif chain and an import failure in one never breaks the rest.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from ..errors import UserError

# (name, module, help) — modules are imported only when their command runs
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("validate", "opends_gym.cli.validate", "load and check OpenDS driving tasks"),
    ("list", "opends_gym.cli.listing", "list bundled tasks and registered environments"),
    ("run", "opends_gym.cli.run", "drive an environment with an agent and print its metrics"),
    ("drive", "opends_gym.cli.drive", "drive a task yourself in real time (keyboard, wheel, CAN) and print the metrics"),
    ("replay", "opends_gym.cli.replay", "re-simulate a recorded drive and check it is exact"),
    ("analyze", "opends_gym.cli.analyze", "drive measures, CSV and PDF report of a recording or OpenDS carData.txt"),
    ("train", "opends_gym.cli.train", "train a baseline policy from a YAML config or a bundled one by name"),
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="opends-gym", description="OpenDS driving tasks as Gymnasium environments")
    parser.add_argument("--log-level", default="WARNING", help="logging level (DEBUG, INFO, WARNING, ERROR)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module, help_text in COMMANDS:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        importlib.import_module(module).add_arguments(p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    try:
        code = importlib.import_module(args._module).run(args)
    except UserError as e:  # a missing extra, a name that is no bundled file, ...: one line
        print(f"opends-gym: {e}", file=sys.stderr)
        return 2
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
