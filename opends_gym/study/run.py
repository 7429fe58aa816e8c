"""Run a study's virtual participants and write its folder: rows, table, summary, report.

Folder layout (OUT/): virtual.csv (the virtual rows), human/ID/ (a person's blocks, see
`study.human`), table.csv + table.parquet (every row), summary.csv + summary.json (the effects),
report.html, participants.csv (the population's parameters, when the participant model runs).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..jsonsafe import dump_json
from .analysis import Effect, summarize
from .backend import run_trials
from .config import Study
from .design import expand, participant_label
from .table import VIRTUAL_ROWS, write_rows, write_table


def run_virtual(
    study: Study,
    out: Path,
    workers: int = 1,
    cluster: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    backend: str | None = None,
) -> dict[str, Any]:
    """Every virtual trial, then the table, summary and report; returns what was written
    (`backend`: overrides the study's)."""
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    cpu = time.process_time() + _children_cpu_s()
    trials = expand(study)
    backend = backend or study.backend
    rows = run_trials(
        trials, study.participants, study.seed, workers=workers, cluster=cluster, use_ray=study.ray, progress=progress, backend=backend
    )
    write_rows(out / VIRTUAL_ROWS, rows)
    run_s = time.perf_counter() - started
    cpu_s = time.process_time() + _children_cpu_s() - cpu  # this process's and its workers' CPU seconds
    _write_participants(study, out)
    agents = {t.condition: t.agent for t in trials if t.participant == 0}  # who drove (participant 0's spec)
    written = finish(study, out, run_s, {"agents": agents, "workers": workers, "cluster": cluster, "backend": backend, "cpu_s": cpu_s})
    written.update(trials=len(trials), rows=len(rows), run_s=run_s, cpu_s=cpu_s, agents=agents, backend=backend)
    return written


def _children_cpu_s() -> float:
    """CPU seconds of this process's finished worker processes (a pool's), so far."""
    try:
        import resource
    except ImportError:  # (not on Windows)
        return 0.0
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def finish(study: Study, out: Path, run_s: float | None = None, meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """Rebuild table, summary and report from every row file in `out`."""
    from .report import write_report

    csv_path, parquet_path, table = write_table(out)
    p = study.power
    effects = summarize(
        table,
        [c.name for c in study.conditions],
        study.reference,
        target=p.target,
        alpha=p.alpha,
        simulations=p.simulations,
        max_n=p.max_n,
        bootstrap=study.bootstrap,
        seed=study.seed,
    )
    summary_csv = _write_summary(out, effects)
    with (out / "summary.json").open("w", encoding="utf-8") as f:
        head = {"study": study.name, "reference": study.reference, "participants": study.participants, "seed": study.seed}
        dump_json({**head, "run_s": run_s, **(meta or {}), "effects": [e.as_dict() for e in effects]}, f)
    report = write_report(out / "report.html", study, table, effects, run_s)
    return {"table_csv": csv_path, "table_parquet": parquet_path, "summary": summary_csv, "report": report, "effects": effects}


def _write_summary(out: Path, effects: list[Effect]) -> Path:
    path = out / "summary.csv"
    names = [f.name for f in dataclasses.fields(Effect)]
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(names)
        for e in effects:
            w.writerow([_cell(getattr(e, n)) for n in names])
    return path


def _cell(v: Any) -> Any:
    return "" if isinstance(v, float) and math.isnan(v) else v


def _write_participants(study: Study, out: Path) -> None:
    """The drawn parameters of each virtual participant (when a condition uses the participant model)."""
    from .agents import population

    if not any("participant" in (c.agent or study.agent) for c in study.conditions):
        return
    params = population(study.participants, study.seed)
    rows = [{"participant": participant_label(k), **_fields(p)} for k, p in enumerate(params)]
    with (out / "participants.csv").open("w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _fields(params: Any) -> dict[str, Any]:
    if dataclasses.is_dataclass(params) and not isinstance(params, type):
        return dataclasses.asdict(params)
    return json.loads(json.dumps(vars(params), default=str)) if hasattr(params, "__dict__") else {"params": str(params)}
