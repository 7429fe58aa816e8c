"""A person drives a study: Latin-square condition order, an instruction page before each
block, one human-mode drive (and one MCAP recording) per block, rows in the study table.

Why block by block on disk: a session of an hour must survive a crash, a pulled cable or a
participant who needs a break. Each finished block's rows are written (atomically) the
moment it ends, beside its recording; a drive that did not end (quit, window closed, crash)
leaves no rows, and `--resume` starts at the first block without rows. The order is fixed
in OUT/human/ID/plan.json when the session starts, so a resumed session keeps it.

A block is one (condition, task, repetition); the blocks of a condition are consecutive and
the conditions follow row r of a balanced Latin square (Williams 1949: each condition once in
every position and, for an even count, after every other condition once), r = the
participant's number - 1 (the digits of the id: P07 -> row 6) modulo the number of conditions.
"""

from __future__ import annotations

import json
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import UserError
from .config import Study, env_fields
from .design import env_args_for, trial_seed
from .instructions import show_instructions
from .runner import Row, scalar_metrics
from .table import read_rows, write_rows, write_table

FINISHED = ("task ended", "time limit", "duration reached")  # DriveSession end reasons of a whole drive
SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class HumanOptions:
    participant: str
    inputs: tuple[str, ...] = ("keyboard",)
    window: bool = True
    fast: bool = False
    resume: bool = False
    auto_advance: bool = False
    physics: str = "fast"
    calibration: str | None = None
    dbc: str | None = None
    audio: bool = True


@dataclass(frozen=True)
class Block:
    index: int
    condition: str
    task: str
    trial: int

    @property
    def stem(self) -> str:
        return f"{self.index + 1:02d}-{SAFE.sub('_', self.condition)}-{SAFE.sub('_', self.task)}-{self.trial}"


@dataclass
class HumanResult:
    blocks: int
    done: int
    complete: bool
    stopped_at: int = -1
    lines: list[str] = field(default_factory=list)


def williams_row(n: int, row: int) -> list[int]:
    """Row `row` of a balanced Latin square of order n (Williams design; rows cycle the first)."""
    first = [0]
    lo, hi = 1, n - 1
    for k in range(1, n):
        if k % 2:
            first.append(lo)
            lo += 1
        else:
            first.append(hi)
            hi -= 1
    return [(c + row) % n for c in first]


def latin_square_row(participant: str, n: int) -> int:
    """The participant's row: its number - 1 (`P07` -> 6), or a checksum of an id without digits."""
    digits = re.findall(r"\d+", participant)
    number = int(digits[-1]) - 1 if digits else zlib.crc32(participant.encode())
    return number % n


def plan_blocks(study: Study, participant: str) -> list[Block]:
    names = [c.name for c in study.conditions]
    order = [names[k] for k in williams_row(len(names), latin_square_row(participant, len(names)))]
    blocks: list[Block] = []
    for cond in order:
        for task in study.tasks:
            for rep in range(study.repetitions):
                blocks.append(Block(len(blocks), cond, task.name, rep))
    return blocks


def session_dir(out: Path, participant: str) -> Path:
    if not participant or SAFE.sub("", participant) != participant:
        raise UserError(f"--human {participant!r}: use letters, digits, '_', '-' and '.' only (it names a folder)")
    return out / "human" / participant


def _load_plan(folder: Path, study: Study, blocks: list[Block], resume: bool) -> None:
    plan = folder / "plan.json"
    wanted = {"study": study.name, "blocks": [[b.condition, b.task, b.trial] for b in blocks]}
    if plan.is_file():
        saved = json.loads(plan.read_text(encoding="utf-8"))
        done = len(list((folder / "blocks").glob("*.csv")))
        if not resume:
            raise UserError(
                f"{folder}: participant already has a session ({done} of {len(saved['blocks'])} blocks done);"
                " continue it with --resume, or use another --out or PARTICIPANT_ID"
            )
        if saved != wanted:
            raise UserError(f"{plan}: the study's blocks changed since this session began; it cannot be resumed with this STUDY.yaml")
        return
    if resume:
        raise UserError(f"{folder}: no session to resume for this participant (start it without --resume)")
    folder.mkdir(parents=True, exist_ok=True)
    plan.write_text(json.dumps(wanted, indent=1), encoding="utf-8")


def run_human(study: Study, out: Path, options: HumanOptions) -> HumanResult:
    """Drive every unfinished block of the participant's session; see the module docstring."""
    from ..human.session_config import parse_input_spec

    for c in study.conditions:
        if c.drt is not None:
            raise UserError(f"{study.path}: condition {c.name}: the DRT is not available in human sessions yet")
    for t in study.tasks:
        if t.drt is not None:
            raise UserError(f"{study.path}: task {t.name}: the DRT is not available in human sessions yet")
    try:
        inputs = tuple(parse_input_spec(s) for s in options.inputs)
    except ValueError as e:
        raise UserError(f"--input: {e}") from None
    folder = session_dir(out, options.participant)
    blocks = plan_blocks(study, options.participant)
    _load_plan(folder, study, blocks, options.resume)
    result = HumanResult(blocks=len(blocks), done=0, complete=False)
    for block in blocks:
        rows_path = folder / "blocks" / f"{block.stem}.csv"
        if rows_path.is_file():
            result.done += 1
            continue
        cond = study.condition(block.condition)
        title = f"Block {block.index + 1} of {len(blocks)}: {block.condition} ({block.task})"
        if not show_instructions(
            title, cond.instructions or "Drive as you normally would.", window=options.window, auto_advance=options.auto_advance
        ):
            result.stopped_at = block.index
            return result
        rows, reason, recordings = _drive_block(study, folder, block, inputs, options)
        if rows is None:
            result.stopped_at = block.index
            result.lines.append(f"block {block.index + 1} ({block.condition}, {block.task}) not finished: {reason}")
            return result
        write_rows(rows_path, rows)  # the block is kept from here on, whatever happens next
        write_table(out)
        result.done += 1
        result.lines.append(f"block {block.index + 1} ({block.condition}, {block.task}) done: {', '.join(recordings)}")
    result.complete = True
    csv_path, parquet_path, _ = write_table(out)
    result.lines.append(f"wrote {csv_path}")
    result.lines.append(f"wrote {parquet_path}")
    return result


def _drive_block(
    study: Study, folder: Path, block: Block, inputs: tuple[Any, ...], options: HumanOptions
) -> tuple[list[Row] | None, str, list[str]]:
    from ..human.runner import DriveSession
    from ..human.session_config import DriveConfig

    task_index = next(k for k, t in enumerate(study.tasks) if t.name == block.task)
    task = study.tasks[task_index]
    cond = study.condition(block.condition)
    kwargs = env_args_for(study, task, cond, env_fields(task.env_id))
    kwargs.pop("task", None)  # DriveConfig.target names it
    recording = folder / "recordings" / f"{block.stem}.mcap"
    recording.parent.mkdir(parents=True, exist_ok=True)
    if recording.exists():  # an attempt that did not finish (quit or crash): kept aside, never overwritten
        k = 1
        while recording.with_name(f"{block.stem}.incomplete-{k}.mcap").exists():
            k += 1
        recording.rename(recording.with_name(f"{block.stem}.incomplete-{k}.mcap"))
    config = DriveConfig(
        target=task.target,
        inputs=inputs,
        record_path=str(recording),
        driver=options.participant,
        window=options.window,
        fast=options.fast,
        seed=trial_seed(study.seed, zlib.crc32(options.participant.encode()), task_index, block.trial),
        physics=options.physics,
        calibration=options.calibration,
        dbc=options.dbc,
        audio=options.audio,
        env_kwargs=kwargs,
    )
    try:
        session = DriveSession(config)
    except (ValueError, RuntimeError) as e:
        raise UserError(str(e)) from e
    with session:
        drive = session.run()
    if drive.end_reason not in FINISHED:
        return None, drive.end_reason, drive.recordings
    wanted = task.metrics or study.metrics
    metrics = dict(drive.metrics)
    if wanted is not None:  # a person's drive may lack a measure (no sign reached): a missing value, not a lost block
        metrics = {m: metrics.get(m, float("nan")) for m in wanted}
    where = f"task {block.task}, condition {block.condition}"
    rows: list[Row] = [
        (options.participant, "human", block.condition, block.task, block.trial, m, v) for m, v in scalar_metrics(metrics, wanted, where)
    ]
    return rows, drive.end_reason, drive.recordings


def human_rows(out: Path, participant: str) -> list[Row]:
    """The rows of every finished block of a participant (for tools and tests)."""
    return [r for f in sorted((out / "human" / participant / "blocks").glob("*.csv")) for r in read_rows(f)]
