"""save_task writes OpenDS XML that loads back to an equal task."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from opends_gym.task import load_task, save_task
from opends_gym.task.model_road import Lane

from .conftest import CORPUS, corpus_task_dirs


@pytest.mark.parametrize("folder", corpus_task_dirs(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_round_trip_equals_original(folder: Path, tmp_path: Path) -> None:
    original = load_task(folder)
    entry = save_task(original, tmp_path / "out")
    again = load_task(entry)
    assert again == original
    # saving the reloaded task writes the very same bytes (the writer is deterministic)
    entry2 = save_task(again, tmp_path / "out2")
    for f in entry.parent.glob("*.xml"):
        assert f.read_bytes() == (entry2.parent / f.name).read_bytes(), f.name


def test_saved_files_pass_the_opends_schemas(tmp_path: Path) -> None:
    task = load_task(CORPUS / "opends-cts" / "ReactionTest")
    entry = save_task(task, tmp_path / "rt")
    load_task(entry, strict=True, schema_dir=CORPUS / "opends-cts" / "Schema")


def test_an_edit_survives_saving(tmp_path: Path) -> None:
    task = load_task(CORPUS / "opends-cts" / "ReactionTest")
    road = dataclasses.replace(task.scenario.road, lanes=(*task.scenario.road.lanes, Lane("5", 9.25, 12.95)))
    edited = dataclasses.replace(task, scenario=dataclasses.replace(task.scenario, road=road))
    again = load_task(save_task(edited, tmp_path / "edited"))
    assert again.scenario.road.lane("5") == Lane("5", 9.25, 12.95)
    assert again != task and again == edited
