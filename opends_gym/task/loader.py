"""`load_task`: read an OpenDS task folder into a checked `DrivingTask`."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, TypeVar

from lxml import etree

from . import containment, layer_checks
from .bind import ReadCtx, read_struct
from .bundled import resolve_task_path
from .entry import EntryFile, read_entry_file
from .errors import Diagnostics, TaskError
from .missing_assets import asset_exists, missing_ground, warn_missing_ground
from .model_interaction import Interaction
from .model_scenario import Scenario
from .model_scene import Scene
from .model_settings import Settings
from .model_task import DrivingTask
from .model_taskxml import TaskSpec
from .refs import RefChecker
from .xmlsafe import local_name, parse_file

log = logging.getLogger("opends_gym.task")

T = TypeVar("T")

LAYERS: dict[str, type[Any]] = {
    "scene": Scene,
    "scenario": Scenario,
    "interaction": Interaction,
    "settings": Settings,
    "task": TaskSpec,
}
NAMESPACE = "http://opends.eu/drivingtask/{}"


def _layer_path(folder: Path, entry_path: Path, entry: EntryFile, key: str) -> Path | None:
    name = entry.layer_file(key)
    return containment.layer_file(folder, name, entry_path, key, entry.line_of(key)) if name else None


def _read_layer(path: Path, layer: str, cls: type[T], diag: Diagnostics) -> tuple[T, etree._Element]:
    root = parse_file(path)
    name = local_name(root)
    if name != layer:
        raise TaskError(f"expected a <{layer}> document, found <{name}>", file=path, line=root.sourceline, element=name)
    ns = etree.QName(root).namespace
    if ns and ns != NAMESPACE.format(layer):
        diag.warn(f"unexpected namespace '{ns}'", file=path, line=root.sourceline, element=name)
    return read_struct(cls, root, ReadCtx(path, diag)), root


def _check_asset_keys(scene: Scene, files: dict[str, Path]) -> None:
    where = files.get("scene", files["entry"])
    for kind, items in (("model", scene.models), ("sound", scene.sounds), ("picture", scene.pictures)):
        for item in items:
            containment.check_asset_key(item.key, where, item.line or None, kind)


def _warn_missing_assets(task: DrivingTask, files: dict[str, Path], diag: Diagnostics) -> None:
    scene_file = files.get("scene", files["entry"])
    missing = missing_ground(task.scene, task.folder)
    for g in missing:
        if g.kind == "height map":
            diag.warn(
                f"terrain height map '{g.key}' not found; the ground is flat", scene_file, g.line, "terrain", once_key=f"asset:{g.key}"
            )
    warn_missing_ground(scene_file, task.folder, missing)
    for m in task.scene.models:
        if m.key and not asset_exists(task.folder, m.key):
            diag.warn(
                f"3D model '{m.key}' not found; a box of the declared scale stands in",
                scene_file,
                m.line,
                "model",
                once_key=f"asset:{m.key}",
                log_level=logging.INFO,
            )
    for s in task.scene.sounds:
        if s.key and not asset_exists(task.folder, s.key):
            diag.warn(
                f"sound '{s.key}' not found; it is logged but not played",
                scene_file,
                s.line,
                "sound",
                once_key=f"asset:{s.key}",
                log_level=logging.INFO,
            )
    for p in task.scene.pictures:
        if p.key and not asset_exists(task.folder, p.key):
            diag.warn(f"picture '{p.key}' not found", scene_file, p.line, "picture", once_key=f"asset:{p.key}", log_level=logging.INFO)
    od = task.open_drive_path
    if od is not None and not od.is_file():
        diag.warn(f"OpenDRIVE file '{task.entry.open_drive}' not found", files["entry"], None, "entry")


def load_task(path: str | Path, *, strict: bool = False, schema_dir: str | Path | None = None) -> DrivingTask:
    """Load a task from its folder, its entry file, or a bundled task's name.

    Raises `TaskError` (file, line, element in the message) for anything that makes the
    task unusable; tolerable problems become `DrivingTask.warnings`. With `strict=True`
    each layer file is also validated against the OpenDS XSD (see `strict.py`).
    """
    entry_path = resolve_task_path(path)
    folder = entry_path.parent
    diag = Diagnostics()
    entry = read_entry_file(entry_path, diag)
    files: dict[str, Path] = {"entry": entry_path}
    parts: dict[str, Any] = {}
    roots: dict[str, etree._Element] = {}
    for layer, cls in LAYERS.items():
        lp = _layer_path(folder, entry_path, entry, layer)
        if lp is None:
            if layer in ("interaction", "settings"):
                diag.warn(f"no '{layer}' entry; an empty {layer} is used", entry_path, None, "properties")
            parts[layer] = cls() if layer != "task" else None
            continue
        if not containment.is_file(lp, entry_path, layer, entry.line_of(layer)):
            msg = f"the entry file names '{lp.name}' for {layer}, but it does not exist"
            raise TaskError(msg, entry_path, entry.line_of(layer), "entry")
        files[layer] = lp
        parts[layer], roots[layer] = _read_layer(lp, layer, cls, diag)
    if strict:
        from .strict import validate_against_xsd

        for layer, root in roots.items():
            validate_against_xsd(files[layer], root, layer, schema_dir)
    _check_asset_keys(parts["scene"], files)
    od = _layer_path(folder, entry_path, entry, "openDrive")
    if od is not None and containment.is_file(od, entry_path, "openDrive", entry.line_of("openDrive")):
        layer_checks.run("openDrive", od)
    RefChecker(files, diag).check(parts["scene"], parts["scenario"], parts["interaction"], parts["task"])
    task = DrivingTask(
        name=entry_path.stem,
        entry=entry,
        scene=parts["scene"],
        scenario=parts["scenario"],
        interaction=parts["interaction"],
        settings=parts["settings"],
        task=parts["task"],
        folder=folder,
    )
    _warn_missing_assets(task, files, diag)
    return DrivingTask(**{**task.__dict__, "warnings": tuple(diag.warnings)})
