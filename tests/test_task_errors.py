"""Bad task files give one exception type naming the file, line and element.

What OpenDS tolerates (unknown actions, missing assets, boolean typos in the entry file,
remote DTDs) loads with warnings instead.
"""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from opends_gym.task import TaskError, load_task

from .conftest import CORPUS, line_of

CONTRE = "opends-cts/ConTReTask"
REACTION = "opends-cts/ReactionTest"


def _assert_error(exc: TaskError, file: Path, line: int, element: str | None) -> None:
    assert exc.file is not None and Path(exc.file).name == file.name
    assert exc.line == line
    if element is not None:
        assert exc.element == element
    text = str(exc)
    assert f"{file.name}:{line}" in text


def test_malformed_xml(task_copy) -> None:
    folder = task_copy(CONTRE, "scenario.xml", "<traffic>", "<traffic")
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "malformed XML" in str(info.value)
    assert info.value.file is not None and info.value.file.endswith("scenario.xml")
    assert info.value.line is not None and info.value.line > 1


def test_missing_required_element(task_copy) -> None:
    folder = task_copy(CONTRE, "interaction.xml", "<condition>remote:resume</condition>", "")
    trigger_line = line_of(CORPUS / CONTRE / "interaction.xml", "<condition>remote:resume</condition>")
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "missing required element <condition>" in str(info.value)
    assert info.value.element == "trigger"
    assert info.value.line is not None and info.value.line < trigger_line


def test_wrong_type(task_copy) -> None:
    folder = task_copy(REACTION, "scenario.xml", "<maxSpeed>60</maxSpeed>", "<maxSpeed>sixty</maxSpeed>")
    f = folder / "scenario.xml"
    with pytest.raises(TaskError) as info:
        load_task(folder)
    _assert_error(info.value, f, line_of(f, "<maxSpeed>sixty"), "maxSpeed")
    assert "'sixty' is not a valid number" in str(info.value)


def test_wrong_type_in_action_parameter(task_copy) -> None:
    folder = task_copy(
        REACTION, "interaction.xml", '<parameter name="startSpeed" value="50"/>', '<parameter name="startSpeed" value="fast"/>'
    )
    f = folder / "interaction.xml"
    with pytest.raises(TaskError) as info:
        load_task(folder)
    _assert_error(info.value, f, line_of(f, 'value="fast"'), "parameter")


def test_dangling_reference(task_copy) -> None:
    folder = task_copy(REACTION, "scenario.xml", 'ref="Ferrari"', 'ref="Porsche"')
    f = folder / "scenario.xml"
    with pytest.raises(TaskError) as info:
        load_task(folder)
    _assert_error(info.value, f, line_of(f, 'ref="Porsche"'), "car")
    assert "'Porsche' names nothing" in str(info.value)


def test_dangling_activity_reference(task_copy) -> None:
    folder = task_copy(REACTION, "interaction.xml", '<activity ref="Start_startRM"/>', '<activity ref="Start_nothing"/>')
    f = folder / "interaction.xml"
    with pytest.raises(TaskError) as info:
        load_task(folder)
    _assert_error(info.value, f, line_of(f, "Start_nothing"), "activity")


def test_duplicate_id(task_copy) -> None:
    folder = task_copy(REACTION, "scenario.xml", '<lane id="3">', '<lane id="1">')
    f = folder / "scenario.xml"
    with pytest.raises(TaskError) as info:
        load_task(folder)
    second = [i for i, text in enumerate(f.read_text().splitlines(), 1) if '<lane id="1">' in text][1]
    _assert_error(info.value, f, second, "lane")
    assert "duplicate id '1'" in str(info.value)


def test_referenced_model_id_must_be_unique(task_copy) -> None:
    # 2500 road tiles share an id harmlessly; naming such an id as the car is ambiguous
    folder = task_copy(REACTION, "scenario.xml", 'ref="Ferrari"', 'ref="road_5lane"')
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "ambiguous" in str(info.value) and "2500" in str(info.value)


def test_missing_layer_file(task_copy) -> None:
    folder = task_copy(CONTRE)
    (folder / "settings.xml").unlink()
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "settings.xml" in str(info.value) and info.value.file is not None and info.value.file.endswith("conTReTask.xml")


def test_wrong_root_element(task_copy) -> None:
    folder = task_copy(CONTRE)
    (folder / "scene.xml").write_bytes((folder / "settings.xml").read_bytes())
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert "expected a <scene> document, found <settings>" in str(info.value)


def test_unknown_action_warns_once_and_loads(task_copy) -> None:
    # The corpus has moveObject only inside comments; uncomment a trigger that uses it.
    folder = task_copy(
        "opends-cts/Idealtest2",
        "interaction.xml",
        '<activity ref="activity04"/>',
        '<activity ref="activity04"/><activity id="inline1"><action id="moveObject" delay="0" repeat="1">'
        '<parameter name="id" value="redBox"/></action><action id="moveObject" delay="0" repeat="1"/></activity>',
    )
    task = load_task(folder)
    unknown = [w for w in task.warnings if "unknown action 'moveObject'" in w.message]
    assert len(unknown) == 1 and unknown[0].line is not None


def test_missing_assets_and_boolean_typos_only_warn() -> None:
    task = load_task(CORPUS / "opends2023-annegretj" / "init_drive")
    assert any("falsse" in w.message and w.element == "entry" for w in task.warnings)
    contre = load_task(CORPUS / CONTRE)
    assert any("not found" in w.message and "Car.j3o" in w.message for w in contre.warnings)


def test_remote_dtd_is_never_fetched(monkeypatch) -> None:
    def no_network(*args, **kwargs):
        raise AssertionError("the loader tried to open a network connection")

    monkeypatch.setattr(socket, "create_connection", no_network)
    monkeypatch.setattr(socket.socket, "connect", no_network)
    task = load_task(CORPUS / REACTION)  # its entry file names http://java.sun.com/dtd/properties.dtd
    assert task.name == "reactionTest"


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE scene [
 <!ENTITY a "aaaaaaaaaa">
 <!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">
 <!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">
 <!ENTITY d "&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;">
 <!ENTITY e "&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;">
 <!ENTITY f "&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;">
 <!ENTITY g "&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;">
 <!ENTITY h "&g;&g;&g;&g;&g;&g;&g;&g;&g;&g;">
 <!ENTITY i "&h;&h;&h;&h;&h;&h;&h;&h;&h;&h;">
]>
<scene xmlns="http://opends.eu/drivingtask/scene"><skyTexture>&i;</skyTexture></scene>
"""

EXTERNAL_ENTITY = """<?xml version="1.0"?>
<!DOCTYPE scene [ <!ENTITY secret SYSTEM "file:///etc/passwd"> ]>
<scene xmlns="http://opends.eu/drivingtask/scene"><skyTexture>&secret;</skyTexture></scene>
"""


@pytest.mark.parametrize(
    "payload,entity,line", [(BILLION_LAUGHS, "a", 3), (EXTERNAL_ENTITY, "secret", 2)], ids=["billion-laughs", "external-entity"]
)
def test_hostile_xml_is_refused_quickly(task_copy, payload: str, entity: str, line: int) -> None:
    folder = task_copy(CONTRE)
    (folder / "scene.xml").write_text(payload, encoding="utf-8")
    start = time.perf_counter()
    with pytest.raises(TaskError) as info:
        load_task(folder)
    assert time.perf_counter() - start < 1.0
    assert f"entity '{entity}'" in str(info.value)
    assert info.value.file is not None and info.value.file.endswith("scene.xml")
    assert info.value.line == line
    assert "root:" not in str(info.value)  # nothing of /etc/passwd leaked


def test_strict_mode_checks_the_xsd() -> None:
    load_task(CORPUS / REACTION, strict=True)  # finds ../Schema beside the task
    with pytest.raises(TaskError) as info:
        load_task(CORPUS / "opends-cts" / "ThreeVehiclePlatooningTask", strict=True)
    assert info.value.line == 56 and info.value.element == "displacement"
    assert info.value.file is not None and info.value.file.endswith("scenario.xml")
