"""`opends-gym validate PATH...`: load tasks, print a summary line each, fail on errors."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ..errors import UserError
from ..hints import did_you_mean
from ..sim.lane_sources import road_summary
from ..task import TaskError, load_task
from ..task.bundled import BUNDLED_DIR, bundled_task_names
from ..task.summary import summarize


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("paths", nargs="*", help="task folders, entry files or bundled task names (default: all bundled tasks)")
    p.add_argument("--strict", action="store_true", help="also validate every file against the OpenDS XSDs")
    p.add_argument("--schema-dir", type=Path, help="folder holding scene.xsd, scenario.xsd, ... for --strict")
    p.add_argument("-w", "--show-warnings", action="store_true", help="print each warning under its task")
    p.add_argument("--recursive", action="store_true", help="treat each path as a folder of task folders")


def _check_exists(paths: list[str]) -> None:
    """A path that is neither a file, a folder nor a bundled name is a typo, not a bad task."""
    names = bundled_task_names()
    for p in paths:
        if not Path(p).exists() and p.lower() not in (n.lower() for n in names):
            raise UserError(f"{p}: no such file or folder, and no bundled task of that name{did_you_mean(Path(p).name, names)}")


def _expand(paths: list[str], recursive: bool) -> list[str]:
    if not paths:
        return [str(BUNDLED_DIR / n) for n in bundled_task_names()]
    _check_exists(paths)
    if not recursive:
        return paths
    out: list[str] = []
    for p in paths:
        for entry in sorted(Path(p).rglob("*.xml")):
            if entry.read_bytes()[:2048].find(b"<properties") >= 0:
                out.append(str(entry))
    return out


def run(args: argparse.Namespace) -> int:
    logging.getLogger("opends_gym.task").setLevel(logging.ERROR)  # warnings are printed below
    targets = _expand(list(args.paths), args.recursive)
    if not targets:
        raise UserError(f"no task entry files (XML with <properties>) under {', '.join(args.paths)}")
    if args.schema_dir is not None and not args.schema_dir.is_dir():
        raise UserError(f"--schema-dir {args.schema_dir}: no such folder")
    failed = 0
    for target in targets:
        try:
            task = load_task(target, strict=args.strict, schema_dir=args.schema_dir)
        except TaskError as exc:
            failed += 1
            print(f"ERROR {target}\n      {exc}")
            continue
        print(f"OK    {task.name:<28} {summarize(task, *road_summary(task)).line()}")
        if args.show_warnings:
            for w in task.warnings:
                print(f"      warning: {w}")
    print(f"{len(targets) - failed} of {len(targets)} task(s) valid")
    return 1 if failed else 0
