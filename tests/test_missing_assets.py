"""A task whose terrain height map or ground mesh is missing says so, once, when it is loaded.

Real tasks name OpenDS's own assets (`Textures/Terrain/mountains512.png`, `Scenes/...j3o`),
which a task folder copied out of OpenDS does not carry; the ground is then flat. The
loader raises one `MissingAssetWarning` per task file, naming file, line and element, and
keeps a `TaskWarning` per missing height map.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from opends_gym.sim import World, WorldConfig
from opends_gym.task import load_task
from opends_gym.task.missing_assets import MissingAssetWarning

from .conftest import DRIVES, line_of

HEIGHT_MAP = "Textures/Terrain/mountains512.png"
TERRAIN = f"""<geometries>
        <terrain id="mountains">
            <imageBasedHeightMap key="{HEIGHT_MAP}" heightScale="0.2"/>
        </terrain>
    </geometries>"""
TERRAIN_MODEL = """<models>
        <model id="terrain" key="" ref="mountains"><mass>0</mass><visible>true</visible>
            <translation><vector jtype="java_lang_Float" size="3"><entry>0</entry><entry>-20</entry><entry>0</entry></vector></translation>
        </model>"""


@pytest.fixture
def terrain_task(task_copy) -> Path:  # type: ignore[no-untyped-def]
    """init_drive (OpenDS 2023) with a height-map terrain, as OpenDS's terrain tasks have."""
    folder = task_copy("opends2023-annegretj/init_drive", "scene.xml", "<geometries>\n    </geometries>", TERRAIN)
    scene = folder / "scene.xml"
    scene.write_text(scene.read_text(encoding="utf-8").replace("<models>", TERRAIN_MODEL, 1), encoding="utf-8")
    return folder


def missing_warnings(record: list[warnings.WarningMessage]) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, MissingAssetWarning)]


def test_missing_height_map_warns_once_with_file_line_element(terrain_task: Path) -> None:
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        task = load_task(terrain_task)
    (message,) = missing_warnings(record)
    scene = terrain_task / "scene.xml"
    line = line_of(scene, "<terrain id=")
    assert (
        message == f"{scene}:{line} <terrain>: ground unknown, height map '{HEIGHT_MAP}' not found: the ground is flat there, unlike OpenDS"
    )
    (tw,) = [w for w in task.warnings if w.element == "terrain"]
    assert HEIGHT_MAP in tw.message and tw.line == line


def test_height_map_present_is_not_reported(terrain_task: Path) -> None:
    # init_drive's other models are its grass plane (flat either way) and the driver's car
    from PIL import Image

    image = terrain_task / HEIGHT_MAP
    image.parent.mkdir(parents=True)
    Image.new("L", (8, 8)).save(image)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        task = load_task(terrain_task)
    assert missing_warnings(record) == []
    assert not [w for w in task.warnings if w.element == "terrain"]


def test_missing_scene_mesh_of_a_real_task_warns_once() -> None:
    # the real Countryside task: its roads are the mesh Scenes/Video5/video5.j3o (absent);
    # signs and cars are missing too, but only ground assets are named, once for the file
    scene = DRIVES / "Countryside" / "scene.xml"
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        load_task(DRIVES / "Countryside")
    (message,) = missing_warnings(record)
    assert message.startswith(f"{scene}:{line_of(scene, 'Scenes/Video5/video5.j3o')} <model>: ground unknown, ")
    assert "scene mesh 'Scenes/Video5/video5.j3o', scene mesh 'Scenes/Video5/delimiter.j3o' not found" in message
    assert "grassPlane" not in message and "Car.j3o" not in message and "\n" not in message


def test_bundled_tasks_do_not_warn() -> None:
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        load_task("ReactionTest")
    assert missing_warnings(record) == []


def test_building_the_world_from_a_loaded_task_does_not_warn_again(terrain_task: Path) -> None:
    task = load_task(terrain_task)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        World(task, WorldConfig(traffic=False)).close()
    assert missing_warnings(record) == []
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        World(terrain_task, WorldConfig(traffic=False)).close()
    assert len(missing_warnings(record)) == 1


def test_missing_asset_warning_can_be_an_error(terrain_task: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", MissingAssetWarning)
        with pytest.raises(MissingAssetWarning, match=r"mountains512\.png"):
            load_task(terrain_task)
