"""Keeping a task's file references inside the task.

Why: a task folder comes from anywhere. Its entry file names the layer files and its scene
names model, sound and picture assets; a name like `../../../../etc/passwd` or `/etc/passwd`
would make us open files outside the task. OpenDS resolves layer files against the task
folder and asset keys against its assets root (`Models/Cars/...j3o`), so neither ever needs
an absolute path or a `..` that climbs out.
"""

from __future__ import annotations

import re
from pathlib import Path, PurePosixPath, PureWindowsPath

from .errors import TaskError

_DRIVE = re.compile(r"^[A-Za-z]:")
NAME_MAX, PATH_MAX = 255, 4096  # Linux/Windows limits: a longer key names no file anywhere


def is_absolute_name(name: str) -> bool:
    """Absolute on any OS OpenDS runs on: `/x`, `\\x`, `C:x`, `\\\\host\\x`."""
    return PurePosixPath(name).is_absolute() or PureWindowsPath(name).is_absolute() or name.startswith("\\") or bool(_DRIVE.match(name))


def layer_file(folder: Path, name: str, entry_path: Path, key: str, line: int | None) -> Path:
    """The path of layer file `name`, refused unless it lies inside `folder` (symlinks followed)."""
    if is_absolute_name(name):
        msg = f"{key} file '{_short(name)}' is an absolute path; layer files must lie in the task folder"
        raise TaskError(msg, entry_path, line, "entry")
    try:
        inside = (folder / name).resolve().is_relative_to(folder.resolve())
    except (OSError, RuntimeError, ValueError) as exc:  # name too long, symlink loop, NUL
        raise TaskError(f"{key} file '{_short(name)}' cannot be opened: {_reason(exc)}", entry_path, line, "entry") from None
    if not inside:
        raise TaskError(f"{key} file '{_short(name)}' lies outside the task folder; layer files must lie in it", entry_path, line, "entry")
    return folder / name


def is_file(path: Path, entry_path: Path, key: str, line: int | None) -> bool:
    """`path.is_file()` that turns OSError (a name too long...) into a TaskError."""
    try:
        return path.is_file()
    except (OSError, ValueError) as exc:
        raise TaskError(f"{key} file '{_short(path.name)}' cannot be opened: {_reason(exc)}", entry_path, line, "entry") from None


def check_asset_key(key: str, file: Path, line: int | None, element: str) -> None:
    """Refuse asset keys that are absolute or climb with `..` (missing assets stay a warning)."""
    if not key:
        return
    parts = re.split(r"[\\/]", key)
    why = "is an absolute path" if is_absolute_name(key) else "climbs out with '..'" if ".." in parts else None
    if why is None and (len(key) > PATH_MAX or max(len(p.encode("utf-8", "replace")) for p in parts) > NAME_MAX):
        why = f"is longer than any file name can be ({NAME_MAX} bytes a part, {PATH_MAX} in all)"
    if why is not None:
        raise TaskError(f"asset key '{_short(key)}' {why}; keys are relative to the OpenDS assets folder", file, line, element)


def _reason(exc: BaseException) -> str:
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__


def _short(name: str, limit: int = 80) -> str:
    return name if len(name) <= limit else f"{name[:40]}...{name[-20:]} ({len(name)} characters)"
