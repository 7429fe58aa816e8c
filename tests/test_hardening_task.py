"""Hostile or broken task files (issue 21, cases 1-4 and 10): each gives one clean TaskError
naming file, line and element, through `load_task` and `opends-gym validate`."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from opends_gym.cli.main import main as cli_main
from opends_gym.task import TaskError, load_task
from opends_gym.task.xmlsafe import MAX_ELEMENTS, MAX_FILE_BYTES

from .conftest import line_of

CONTRE = "opends-cts/ConTReTask"
PARIS = "opends35-breznak/ParisTraffic"
INIT_DRIVE = "opends2023-annegretj/init_drive"


def _error(folder: Path) -> TaskError:
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "\n" not in str(info.value)
    return info.value


@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "1e308", "99999999999", "-2147483649", "1" * 5000])
def test_integer_fields_refuse_inf_nan_and_out_of_java_range(task_copy, value: str) -> None:
    folder = task_copy(PARIS, "settings.xml", "<smoothingFactor>10</smoothingFactor>", f"<smoothingFactor>{value}</smoothingFactor>")
    exc = _error(folder)
    assert exc.file is not None and exc.file.endswith("settings.xml")
    assert exc.line == line_of(folder / "settings.xml", "<smoothingFactor>")
    assert exc.element == "smoothingFactor"
    assert "is not a valid integer" in exc.reason and len(str(exc)) < 400


def test_java_int_bounds_still_load(task_copy) -> None:
    folder = task_copy(PARIS, "settings.xml", "<smoothingFactor>10</smoothingFactor>", "<smoothingFactor>2147483647</smoothingFactor>")
    assert load_task(folder).settings is not None


def test_overlong_layer_file_name_is_a_task_error(task_copy) -> None:
    folder = task_copy(CONTRE, "conTReTask.xml", '<entry key="settings">settings.xml', f'<entry key="settings">{"s" * 5000}.xml')
    exc = _error(folder)
    assert exc.file is not None and exc.file.endswith("conTReTask.xml")
    assert exc.line == line_of(folder / "conTReTask.xml", 'key="settings"') and exc.element == "entry"
    assert "File name too long" in exc.reason and len(str(exc)) < 400


@pytest.mark.parametrize("name", ["../../../../etc/passwd", "/etc/passwd", "/proc/self/status", "sub/../../scene.xml"])
def test_layer_files_outside_the_task_folder_are_refused(task_copy, name: str) -> None:
    folder = task_copy(CONTRE, "conTReTask.xml", '<entry key="scene">scene.xml', f'<entry key="scene">{name}')
    exc = _error(folder)
    assert exc.line == line_of(folder / "conTReTask.xml", 'key="scene"') and exc.element == "entry"
    assert "outside the task folder" in exc.reason or "absolute path" in exc.reason


def test_a_symlink_out_of_the_task_folder_is_refused(task_copy, tmp_path: Path) -> None:
    folder = task_copy(CONTRE, "conTReTask.xml", '<entry key="scene">scene.xml', '<entry key="scene">linked.xml')
    outside = tmp_path / "elsewhere.xml"
    outside.write_bytes((folder / "scene.xml").read_bytes())
    os.symlink(outside, folder / "linked.xml")
    assert "outside the task folder" in _error(folder).reason


def test_a_symlink_within_the_task_folder_loads(task_copy) -> None:
    folder = task_copy(CONTRE, "conTReTask.xml", '<entry key="scene">scene.xml', '<entry key="scene">linked.xml')
    os.symlink(folder / "scene.xml", folder / "linked.xml")
    assert load_task(folder).scene.models


@pytest.mark.parametrize(
    "key", ["/etc/passwd", "../../../../../etc/passwd", "Models/../../../../x.obj", "C:\\Windows\\x.j3o", "Models/" + "x" * 5000 + ".obj"]
)
def test_model_keys_that_leave_the_assets_are_refused(task_copy, key: str) -> None:
    old = 'key="Models/Cars/drivingCars/AudiS6/Car.j3o"'
    folder = task_copy(CONTRE, "scene.xml", old, f'key="{key}"')
    exc = _error(folder)
    assert exc.file is not None and exc.file.endswith("scene.xml") and len(str(exc)) < 400
    assert exc.line == line_of(folder / "scene.xml", f'key="{key}"') and exc.element == "model"


def test_missing_relative_model_assets_only_warn(task_copy) -> None:
    old = 'key="Models/Cars/drivingCars/AudiS6/Car.j3o"'
    folder = task_copy(CONTRE, "scene.xml", old, 'key="Models/NoSuch/thing.j3o"')
    task = load_task(folder)
    assert any("Models/NoSuch/thing.j3o" in str(w) for w in task.warnings)


BROKEN_XODR = [
    ('length="2500.0" id="s000"', 'length="2500.0" id="s000" bogus="<"', "malformed XML"),
    ('hdg="3.14159"', 'hdg="north"', "attribute 'hdg'='north' is not a number"),
    ("<line/>", "<clothoid/>", "unknown geometry type <clothoid>"),
    ('length="2500.0" id="s000"', 'length="1e12" id="s000"', "the cap is"),
    ("<OpenDRIVE>", "<OpenDRIVEX>", "malformed XML"),
]


@pytest.mark.parametrize(("old", "new", "reason"), BROKEN_XODR)
def test_broken_opendrive_fails_at_load_and_validate(task_copy, capsys, old: str, new: str, reason: str) -> None:
    folder = task_copy(INIT_DRIVE, "road.xodr", old, new)
    exc = _error(folder)
    assert exc.file is not None and exc.file.endswith("road.xodr") and exc.line is not None
    assert reason in exc.reason
    assert cli_main(["validate", str(folder)]) == 1
    assert f"road.xodr:{exc.line}" in capsys.readouterr().out


def test_opendrive_outside_the_task_folder_is_refused(task_copy) -> None:
    folder = task_copy(INIT_DRIVE, "init_drive.xml", "road.xodr", "../../road.xodr")
    assert "outside the task folder" in _error(folder).reason


def test_an_oversized_scene_fails_fast(task_copy) -> None:
    """The issue's 18 MB scene of 300,000 models cost 8.8 s and 575 MB before an error."""
    folder = task_copy(CONTRE)
    model = '<model id="m{}" key="Models/x.j3o"><scale><vector jtype="java_lang_Float" size="3"><entry>1</entry></vector></scale></model>\n'
    text = (folder / "scene.xml").read_text(encoding="utf-8")
    head, tail = text.split("<models>", 1)
    (folder / "scene.xml").write_text(head + "<models>" + "".join(model.format(i) for i in range(150_000)) + tail, encoding="utf-8")
    assert (folder / "scene.xml").stat().st_size > MAX_FILE_BYTES
    t0 = time.perf_counter()
    exc = _error(folder)
    assert time.perf_counter() - t0 < 1.0
    assert exc.file is not None and exc.file.endswith("scene.xml") and "MiB (the cap" in exc.reason


def test_too_many_elements_fail_with_the_line_of_the_first_one_over(task_copy) -> None:
    folder = task_copy(CONTRE)
    text = (folder / "scene.xml").read_text(encoding="utf-8")
    head, tail = text.split("<models>", 1)
    (folder / "scene.xml").write_text(head + "<models>\n" + "<a/>\n" * MAX_ELEMENTS + tail, encoding="utf-8")
    t0 = time.perf_counter()
    exc = _error(folder)
    assert time.perf_counter() - t0 < 1.0  # counted before parsing, not after building a tree
    assert exc.line is not None and exc.line > MAX_ELEMENTS - 1000 and "elements in one file" in exc.reason and exc.element == "a"
