"""`opends-gym analyze REC [--ideal-track ID] [--csv OUT] [--report OUT.pdf] [--json]`.

REC is an MCAP recording or an OpenDS carData.txt (any variant; reactionData.xml and
drivingTaskLog.txt beside it are read too). Prints the measures; `--csv` writes the
per-sample table plus `<stem>_metrics.csv` (and `<stem>_reactions.csv`); `--report`
writes the PDF and a PNG per page beside it; `--export-opends DIR` writes carData.txt,
reactionData.xml and drivingTaskLog.txt for OpenDS's tools.
"""

from __future__ import annotations

import argparse
import sys


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", help="MCAP recording or OpenDS carData.txt")
    p.add_argument("--ideal-track", default=None, metavar="ID", help="only this ideal track (lct_normative for the Lane Change Test)")
    p.add_argument("--task", default=None, help="driving task of a carData.txt (default: its 'Driving Task:' line)")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="per-sample table (+ _metrics.csv, _reactions.csv)")
    p.add_argument("--report", default=None, metavar="OUT.pdf", help="PDF report (and PNGs beside it)")
    p.add_argument("--no-png", action="store_true", help="with --report: skip the PNG files")
    p.add_argument("--export-opends", default=None, metavar="DIR", help="write carData.txt, reactionData.xml, drivingTaskLog.txt")
    p.add_argument("--json", action="store_true", help="print the measures as one JSON object")
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
    written: list[object] = []
    if args.csv:
        written += write_csv(a, args.csv)
    if args.report:
        from ..record.report import write_report

        pages = write_report(a, args.report, png=not args.no_png)
        written.append(f"{args.report} ({len(pages)} pages: {', '.join(pages)})")
    if args.export_opends:
        from ..record.export import export_opends

        try:
            written += export_opends(drive, args.export_opends)
        except FileExistsError as e:
            print(f"analyze: {e}", file=sys.stderr)
            return 2
    if args.json:
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
    for w in written:
        print(f"wrote {w}", file=sys.stderr if args.json else sys.stdout)
    return 0
