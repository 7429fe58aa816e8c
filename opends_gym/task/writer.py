"""`save_task`: write a `DrivingTask` back out as OpenDS-format XML files."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

from lxml import etree

from .bind import WriteCtx, write_struct
from .entry import write_entry_file
from .loader import NAMESPACE
from .model_task import DrivingTask

XSI = "http://www.w3.org/2001/XMLSchema-instance"


def layer_document(layer: str, obj: Any) -> bytes:
    """One layer (`scene`, `scenario`, ...) as an XML document in the OpenDS namespace."""
    ns = NAMESPACE.format(layer)
    root = etree.Element(f"{{{ns}}}{layer}", nsmap={None: ns, "xsi": XSI})
    root.set(f"{{{XSI}}}schemaLocation", f"{ns} ../../Schema/{layer}.xsd")
    write_struct(obj, root, WriteCtx(ns))
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8", standalone=False)


def save_task(task: DrivingTask, folder: str | Path) -> Path:
    """Write the task into `folder` (created if needed) and return its entry file.

    File names follow the task's entry file; the OpenDRIVE file, if any, is copied.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    entry = task.entry
    names = {
        "scene": entry.scene or "scene.xml",
        "scenario": entry.scenario or "scenario.xml",
        "interaction": entry.interaction or "interaction.xml",
        "settings": entry.settings or "settings.xml",
    }
    parts: dict[str, Any] = {
        "scene": task.scene,
        "scenario": task.scenario,
        "interaction": task.interaction,
        "settings": task.settings,
    }
    if task.task is not None:
        names["task"] = entry.task or "task.xml"
        parts["task"] = task.task
    for layer, obj in parts.items():
        target = out / names[layer]
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(layer_document(layer, obj))
    entry = replace(entry, interaction=names["interaction"], settings=names["settings"], task=names.get("task"))
    if entry.open_drive:
        src = task.folder / entry.open_drive
        if src.is_file():
            dst = out / entry.open_drive
            dst.parent.mkdir(parents=True, exist_ok=True)
            if src.resolve() != dst.resolve():
                shutil.copyfile(src, dst)
    entry_path = out / entry.file_name
    write_entry_file(entry, entry_path)
    return entry_path
