"""OpenDS's other analyzer outputs: `reactionData.xml` and `drivingTaskLog.txt`.

Why: OpenDS writes both beside `carData.txt` in `analyzerData/<date>/`; its report
templates and many labs' scripts read them. We write them from our recordings and read
them back, so OpenDS sessions can be analysed here and ours in OpenDS tools.

* `reactionData.xml` (`eu.opends.reactionCenter.ReactionLogger`): `<report>` with one
  `<reactionMeasurement>` per trial: reactionGroup, reactionResult (1 correct, -1 failure,
  -2 missed), reactionTime (ms; misses 10000), absoluteTime (epoch ms), experimentTime
  (ms since startReactionMeasurement), comment.
* `drivingTaskLog.txt` (`eu.opends.analyzer.DrivingTaskLogger`): `Driver:`, `Driving
  Task:`, `Start Time:` and a blank line, then `yyyy-MM-dd HH:mm:ss.SSS --> text` lines. We
  write report texts, speed reports, measureTimeUntil results ("reaction time at
  '<trigger>': mm:ss.SSS", OpenDS's wording) and one line per scored reaction trial.
"""

from __future__ import annotations

import datetime as _dt
import logging
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

from lxml import etree

log = logging.getLogger(__name__)

RESULT_WORDS = {1: "correct", -1: "failure", -2: "missed"}
_LOG_LINE = re.compile(r"^(\d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2}\.\d{3}) --> (.*)$")


def _stamp(epoch_ms: int) -> str:
    """Local time, as OpenDS's SimpleDateFormat writes it (carData/reactionData hold epochs)."""
    d = _dt.datetime.fromtimestamp(epoch_ms // 1000)
    return d.strftime("%Y-%m-%d %H:%M:%S.") + f"{epoch_ms % 1000:03d}"


def _parse_stamp(text: str) -> int:
    d = _dt.datetime.strptime(text, "%Y-%m-%d %H:%M:%S.%f")
    return int(round(d.timestamp() * 1000))


def _mmss(seconds: float) -> str:
    ms = int(round(seconds * 1000))
    return f"{ms // 60000:02d}:{(ms // 1000) % 60:02d}.{ms % 1000:03d}"


# ------------------------------------------------------------------ reactionData.xml
def write_reaction_data(path: str | Path, reactions: Iterable[dict[str, Any]], start_epoch_ms: int = 0) -> Path:
    """reactionData.xml from reaction dicts (`ReactionResult` fields, times in seconds)."""
    out = ['<?xml version="1.0"?>', "<report>"]
    for r in reactions:
        out += [
            "\t<reactionMeasurement>",
            f"\t\t<reactionGroup>{escape(str(r.get('group', '')))}</reactionGroup>",
            f"\t\t<reactionResult>{int(r['result'])}</reactionResult>",
            f"\t\t<reactionTime>{int(round(float(r['reaction_time_s']) * 1000))}</reactionTime>",
            f"\t\t<absoluteTime>{start_epoch_ms + int(round(float(r['t_s']) * 1000))}</absoluteTime>",
            f"\t\t<experimentTime>{int(round(float(r.get('experiment_time_s', r['t_s'])) * 1000))}</experimentTime>",
            f"\t\t<comment>{escape(str(r.get('comment', '')))}</comment>",
            "\t</reactionMeasurement>",
        ]
    out.append("</report>")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("\n".join(out) + "\n", encoding="utf-8")
    return p


def read_reaction_data(path: str | Path) -> list[dict[str, Any]]:
    """Trials of a reactionData.xml (times in seconds; `t_s` is relative to the first trial's
    absolute time unless `start_epoch_ms` is known to the caller: `absolute_ms` is kept).

    OpenDS does not escape comments; a file with a stray `&` is read in recovery mode and a
    warning names it. A file with no `<report>` root is an error naming the file.
    """
    p = Path(path)
    parser = etree.XMLParser(resolve_entities=False, no_network=True, recover=True)
    try:
        root = etree.parse(str(p), parser).getroot()
    except (etree.XMLSyntaxError, OSError) as e:
        raise ValueError(f"{p}: cannot read reaction data: {e}") from e
    if root is None or root.tag != "report":
        raise ValueError(f"{p}: not an OpenDS reactionData.xml (root must be <report>)")
    if parser.error_log:
        log.warning("%s: repaired malformed XML (%s)", p, parser.error_log[0])
    out = []
    for k, m in enumerate(root.iter("reactionMeasurement")):

        def text(tag: str, default: str = "", m: Any = m) -> str:
            el = m.find(tag)
            return (el.text or "").strip() if el is not None else default

        try:
            out.append(
                {
                    "timer_id": f"trial{k + 1}",
                    "group": text("reactionGroup"),
                    "result": int(text("reactionResult", "0")),
                    "reaction_time_s": int(text("reactionTime", "0")) / 1000.0,
                    "absolute_ms": int(text("absoluteTime", "0")),
                    "experiment_time_s": int(text("experimentTime", "0")) / 1000.0,
                    "comment": text("comment"),
                }
            )
        except ValueError as e:
            raise ValueError(f"{p}:{m.sourceline}: bad number in <reactionMeasurement>: {e}") from None
    return out


# ------------------------------------------------------------------ drivingTaskLog.txt
def log_lines(events: Iterable[dict[str, Any]], reactions: Iterable[dict[str, Any]]) -> list[tuple[float, str]]:
    """(sim time, text) lines in OpenDS's wording for report events, measurements and trials."""
    lines: list[tuple[float, str]] = []
    for e in events:
        kind, params = e.get("kind"), e.get("params") or {}
        if kind == "report" and "text" in params:
            lines.append((e["t_s"], str(params["text"])))
        elif kind == "report" and params.get("what") == "speed":
            limit = f"{params['type']} {float(params['threshold_kmh']):.1f} km/h: {params['condition_met']}"
            lines.append((e["t_s"], f"speed: {float(params['speed_kmh']):.1f} km/h ({limit})"))
        elif kind == "report" and params.get("what") == "traffic_light":
            lines.append((e["t_s"], f"traffic light '{params['light']}' is {params['state']} (expected {params['expected']})"))
        elif kind == "measurement":
            lines.append((e["t_s"], f"reaction time at '{e['source']}': {_mmss(float(params['elapsed_s']))}"))
        elif kind == "collision":
            lines.append((e["t_s"], f"collision with '{e['source']}'"))
    for r in reactions:
        word = RESULT_WORDS.get(int(r["result"]), str(r["result"]))
        text = f"reaction {r.get('group', '')} '{r.get('timer_id', '')}': {word}, reaction time {_mmss(float(r['reaction_time_s']))}"
        if r.get("comment"):
            text += f" ({r['comment']})"
        lines.append((float(r["t_s"]), text))
    lines.sort(key=lambda x: x[0])
    return lines


def write_driving_task_log(
    path: str | Path,
    events: Iterable[dict[str, Any]],
    reactions: Iterable[dict[str, Any]],
    *,
    driver: str = "",
    driving_task: str = "",
    start_epoch_ms: int = 0,
) -> Path:
    out = [f"Driver: {driver}", f"Driving Task: {driving_task}", f"Start Time: {_stamp(start_epoch_ms)}", ""]
    for t, text in log_lines(events, reactions):
        out.append(f"{_stamp(start_epoch_ms + int(round(t * 1000)))} --> {text}")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("\n".join(out) + "\n", encoding="utf-8")
    return p


def read_driving_task_log(path: str | Path) -> tuple[dict[str, str], list[tuple[int, str]]]:
    """(header fields, [(epoch ms, text)]). Lines without a timestamp (TrialLogger rows) keep epoch -1."""
    header: dict[str, str] = {}
    entries: list[tuple[int, str]] = []
    for line in Path(path).read_text(encoding="utf-8", errors="replace").splitlines():
        m = _LOG_LINE.match(line)
        if m:
            entries.append((_parse_stamp(m.group(1)), m.group(2)))
        elif ":" in line and not entries and line.split(":", 1)[0] in ("Driver", "Driving Task", "Start Time"):
            k, v = line.split(":", 1)
            header[k] = v.strip()
        elif line.strip():
            entries.append((-1, line.strip()))
    return header, entries
