"""`opends-gym`: one entry point, one module per sub-command.

Why: sub-commands register themselves from their own modules (`add_parser` + `run`), so
adding one touches no if/elif chain and an import failure in one never breaks the rest.
A mistake the user made (`UserError`, a broken task, a missing file or extra) is one line
on stderr and exit status 2; `--debug` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import re
import sys
from collections.abc import Sequence
from typing import NoReturn

from ..errors import UserError
from ..extras import extra_of_module
from ..hints import closest, did_you_mean

# (name, module, help) — modules are imported only when their command runs
COMMANDS: tuple[tuple[str, str, str], ...] = (
    ("validate", "opends_gym.cli.validate", "load and check OpenDS driving tasks"),
    ("list", "opends_gym.cli.listing", "list bundled tasks and registered environments"),
    ("run", "opends_gym.cli.run", "drive an environment with an agent and print its metrics"),
    ("drive", "opends_gym.cli.drive", "drive a task yourself in real time (keyboard, wheel, CAN) and print the metrics"),
    ("replay", "opends_gym.cli.replay", "re-simulate a recorded drive and check it is exact"),
    ("analyze", "opends_gym.cli.analyze", "drive measures, CSV and PDF report of a recording or OpenDS carData.txt"),
    ("conform", "opends_gym.cli.conform", "replay a real OpenDS carData.txt open loop through the vehicle model and compare"),
    ("export", "opends_gym.cli.export", "turn recordings and OpenDS carData.txt logs into a Minari dataset"),
    ("study", "opends_gym.cli.study", "run a study (participants x conditions x tasks) on virtual participants or a person"),
    ("train", "opends_gym.cli.train", "train a baseline policy from a YAML config or a bundled one by name"),
    ("compile", "opends_gym.cli.compile", "compile the envs' kernels into this machine's numba cache, so first steps wait for none"),
)

LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")
_INVALID_CHOICE = re.compile(r"invalid choice: '?([^'\s]*)'? \(choose from (.*)\)$")


class Parser(argparse.ArgumentParser):
    """argparse whose errors are one line (no usage block) with a did-you-mean."""

    def error(self, message: str) -> NoReturn:
        m = _INVALID_CHOICE.search(message)
        if m:
            choices = [c.strip().strip("'\"") for c in m.group(2).split(",")]
            match = closest(m.group(1), choices)
            if match:
                message += f"; did you mean {match}?"
        elif message.startswith("unrecognized arguments:"):
            words = message.split(":", 1)[1].split()
            options = [o for o in self._option_string_actions if o.startswith("--")]
            match = next((closest(w.split("=")[0], options) for w in words if w.startswith("--")), None)
            if match:
                message += f"; did you mean {match}?"
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> tuple[Parser, dict[str, Parser]]:
    parser = Parser(prog="opends-gym", description="OpenDS driving tasks as Gymnasium environments")
    parser.add_argument("--log-level", default="WARNING", help="logging level (DEBUG, INFO, WARNING, ERROR)")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error instead of one line")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=Parser)
    commands: dict[str, Parser] = {}
    for name, module, help_text in COMMANDS:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
        importlib.import_module(module).add_arguments(p)
        commands[name] = p
    return parser, commands


def user_message(e: BaseException) -> str | None:
    """The one line to show for an error the user caused, or None for a bug."""
    from ..task.errors import TaskError

    if isinstance(e, ModuleNotFoundError):
        top = (e.name or "").split(".")[0]
        extra = extra_of_module(top)
        if extra is None:
            return f"the Python module '{top}' is not installed (pip install {top})"
        return f"this needs '{top}', which is not installed: pip install \"opends-gym[{extra}]\""
    if isinstance(e, FileNotFoundError) and e.filename is not None:
        return f"{e.filename}: no such file or folder"
    if isinstance(e, (UserError, TaskError, OSError)):
        return str(e)
    return None


def _one_line(text: str) -> str:
    return "; ".join(part.strip() for part in text.splitlines() if part.strip())


def main(argv: Sequence[str] | None = None) -> int:
    parser, commands = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # named by the sub-command's parser, which knows its own options
        commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    level = args.log_level.upper()
    if not isinstance(logging.getLevelName(level), int):
        parser.error(f"argument --log-level: unknown level {args.log_level!r}{did_you_mean(level, LEVELS)}")
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        code = importlib.import_module(args._module).run(args)
    except KeyboardInterrupt:  # Ctrl-C: the user stopped it, no traceback (130 = 128 + SIGINT, as shells report it)
        if args.debug:
            raise
        print(f"opends-gym {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:
        message = None if args.debug else user_message(e)
        if message is None:
            raise
        print(f"opends-gym {args.command}: error: {_one_line(message)}", file=sys.stderr)
        return 2
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
