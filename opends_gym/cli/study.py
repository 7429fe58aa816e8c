"""`opends-gym study STUDY.yaml`: run a study on virtual participants, or `--human ID` for a person.

Virtual: every participant x condition x task x repetition, on `--workers` processes or on Ray
(`--cluster ray://HOST:PORT` or `ray: true`), into OUT/table.csv + table.parquet, a summary
(mixed model, effect sizes, power) and report.html. Human: the same study, block by block in
human mode, Latin-square condition order, each finished block saved at once (`--resume`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import UserError
from .progress import ProgressBar


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {text}")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    examples = "lct_load, brake, drt, drivers"
    p.add_argument("study", metavar="STUDY.yaml", help=f"the study design (docs/studies.md), or a shipped example: {examples}")
    p.add_argument("--out", metavar="DIR", help="results folder (default: ./study-NAME)")
    p.add_argument("--workers", type=positive_int, default=1, help="worker processes for virtual participants (default 1)")
    p.add_argument("--cluster", metavar="ray://HOST:PORT", help="run the virtual participants on this Ray cluster")
    p.add_argument(
        "--backend",
        choices=("auto", "native", "single"),
        help="native: the participants drive the task's native batch; single: one env per drive; "
        "auto (the study's default): native where the task has one",
    )
    p.add_argument("--participants", type=positive_int, help="override the study's number of virtual participants")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: on a terminal)",
    )
    human = p.add_argument_group("human participants")
    human.add_argument("--human", metavar="PARTICIPANT_ID", help="run the study for this person in human mode instead")
    human.add_argument("--resume", action="store_true", help="continue this person's session at the next unfinished block")
    human.add_argument("--auto-advance", action="store_true", help="instruction screens continue by themselves (scripted sessions, tests)")
    human.add_argument(
        "--input",
        action="append",
        default=[],
        metavar="SPEC",
        help="keyboard | joystick | can-tcp[:HOST:PORT] | can-bus[:IFACE:CHANNEL] (repeatable; default keyboard)",
    )
    human.add_argument("--no-window", action="store_true", help="drive without a window (scripted sessions; implies --auto-advance)")
    human.add_argument("--fast", action="store_true", help="do not pace to the wall clock (scripted sessions)")
    human.add_argument("--physics", choices=("fast", "bullet"), default="fast")
    human.add_argument("--calibration", metavar="FILE", help="wheel/pedal calibration (as for opends-gym drive)")
    human.add_argument("--dbc", metavar="FILE", help="DBC file for --input can-bus")
    human.add_argument("--no-audio", action="store_true", help="log sounds without playing them")


def run(args: argparse.Namespace) -> int:
    from ..study.config import load_study

    study = load_study(args.study, participants=args.participants)
    out = Path(args.out) if args.out else Path(f"study-{study.name}")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a folder")
    if args.human is not None:
        return _run_human(args, study, out)
    if args.resume:
        raise UserError("--resume continues a person's session: give --human PARTICIPANT_ID")
    bar = ProgressBar(study.participants, enabled=args.progress)

    def progress(done: int, total: int) -> None:
        bar.update(done, f"participant {done}/{total}")

    try:
        from ..study.run import run_virtual

        written = run_virtual(study, out, workers=args.workers, cluster=args.cluster, progress=progress, backend=args.backend)
    finally:
        bar.close()
    print(
        f"{study.name}: {written['trials']} trials, {written['rows']} rows in {written['run_s']:.1f} s "
        f"({written['cpu_s']:.1f} CPU s, backend {written['backend']})"
    )
    print("agents: " + ", ".join(f"{c} = {a}" for c, a in written["agents"].items()) + " (participant 1's)")
    for key in ("table_csv", "table_parquet", "summary", "report"):
        print(f"wrote {written[key]}")
    return 0


def _run_human(args: argparse.Namespace, study: object, out: Path) -> int:
    from ..study.human import HumanOptions, run_human

    options = HumanOptions(
        participant=args.human,
        inputs=tuple(args.input or ["keyboard"]),
        window=not args.no_window,
        fast=args.fast,
        resume=args.resume,
        auto_advance=args.auto_advance or args.no_window,
        physics=args.physics,
        calibration=args.calibration,
        dbc=args.dbc,
        audio=not args.no_audio,
    )
    result = run_human(study, out, options)  # type: ignore[arg-type]
    for line in result.lines:
        print(line)
    if not result.complete:
        print(
            f"stopped in block {result.stopped_at + 1} of {result.blocks}; {result.done} block(s) saved."
            f" Continue with: opends-gym study {args.study} --human {args.human} --resume",
            file=sys.stderr,
        )
        return 3
    return 0
