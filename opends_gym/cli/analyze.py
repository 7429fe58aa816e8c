"""`opends-gym analyze REC [--ideal-track ID] [--csv OUT] [--report OUT.pdf] [--json] [--against STUDY_OR_POPULATION]`.

REC is an MCAP recording or an OpenDS carData.txt (any variant; reactionData.xml and
drivingTaskLog.txt beside it are read too). Prints the measures; `--csv` writes the
per-sample table plus `<stem>_metrics.csv` (and `<stem>_reactions.csv`); `--report`
writes the PDF and a PNG per page beside it; `--export-opends DIR` writes carData.txt,
reactionData.xml and drivingTaskLog.txt for OpenDS's tools; `--against` adds each metric's
percentile among virtual participants (`opends_gym.data.against`) to the table, JSON and PDF.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import asdict
from typing import Any


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", help="MCAP recording or OpenDS carData.txt")
    p.add_argument("--ideal-track", default=None, metavar="ID", help="only this ideal track (lct_normative for the Lane Change Test)")
    p.add_argument("--task", default=None, help="driving task of a carData.txt (default: its 'Driving Task:' line)")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="per-sample table (+ _metrics.csv, _reactions.csv)")
    p.add_argument("--report", default=None, metavar="OUT.pdf", help="PDF report (and PNGs beside it)")
    p.add_argument("--no-png", action="store_true", help="with --report: skip the PNG files")
    p.add_argument("--export-opends", default=None, metavar="DIR", help="write carData.txt, reactionData.xml, drivingTaskLog.txt")
    p.add_argument("--json", action="store_true", help="print the measures as one JSON object")
    p.add_argument(
        "--against",
        default=None,
        metavar="STUDY_OR_POPULATION",
        help="percentiles among virtual participants: a study folder/table or population:N[:LOAD]",
    )
    p.add_argument("--condition", default=None, help="with --against STUDY: the condition (default: baseline, or the only one)")
    p.add_argument("--study-task", default=None, help="with --against STUDY: the study's task (default: the only one)")
    p.add_argument("--env", default=None, metavar="ENV_ID", help="with --against population: the env of a person's drive or a carData log")
    p.add_argument("--srr-gap-deg", type=float, default=2.0, help="steering reversal gap (steering-wheel degrees)")
    p.add_argument("--srr-cutoff-hz", type=float, default=0.6, help="low-pass cut-off before counting reversals")


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def run(args: argparse.Namespace) -> int:
    from ..record.analyze import AnalyzerParams, analysis_json, analyze, write_csv
    from ..record.drive import load_drive

    try:
        drive = load_drive(args.recording, task=args.task)
        a = analyze(drive, args.ideal_track, AnalyzerParams(srr_gap_deg=args.srr_gap_deg, srr_cutoff_hz=args.srr_cutoff_hz))
    except (ValueError, OSError) as e:
        print(f"analyze: {e}", file=sys.stderr)
        return 2
    placements: list[Any] = []
    against_label = ""
    if args.against:
        from ..data.against import against

        placements, against_label = against(drive, a.rows(), args.against, args.env, args.condition, args.study_task, args.task)
    written: list[object] = []
    if args.csv:
        written += write_csv(a, args.csv)
    if args.report:
        from ..record.report import write_report

        rows = [(p.metric, p.value, p.percentile, p.n, p.median) for p in placements]
        pages = write_report(a, args.report, png=not args.no_png, percentiles=(against_label, rows) if placements else None)
        written.append(f"{args.report} ({len(pages)} pages: {', '.join(pages)})")
    if args.export_opends:
        from ..record.export import export_opends

        try:
            written += export_opends(drive, args.export_opends)
        except FileExistsError as e:
            print(f"analyze: {e}", file=sys.stderr)
            return 2
    if args.json:
        if placements:
            import json

            from ..jsonsafe import json_safe

            obj = json.loads(analysis_json(a))
            obj["against"] = {"reference": against_label, "metrics": json_safe({p.metric: asdict(p) for p in placements})}
            print(json.dumps(obj, indent=1))
        else:
            print(analysis_json(a))
    else:
        print(f"{drive.path} ({drive.source}{'' if drive.complete else ', cut short'}): {drive.n} samples")
        for note in drive.notes:
            print(f"note: {note}")
        section = None
        for sec, name, value, unit in a.rows():
            if sec != section:
                print(f"[{sec}]")
                section = sec
            print(f"  {name:28s} {_fmt(value):>12s} {unit}")
        if placements:
            print(f"[against {against_label}]")
            print(f"  {'metric':34s} {'value':>10s} {'percentile':>10s} {'median':>10s} {'n':>5s}")
            for p in placements:
                print(f"  {p.metric:34s} {_fmt(p.value):>10s} {_fmt(p.percentile):>10s} {_fmt(p.median):>10s} {p.n:5d}")
    for w in written:
        print(f"wrote {w}", file=sys.stderr if args.json else sys.stdout)
    return 0
