"""Bundled tasks (the top-level `tasks/` folder, shipped as `opends_gym/bundled_tasks`).

Why: a user can say `task="ReactionTest"` instead of a path; the same loader reads it.
"""

from __future__ import annotations

from pathlib import Path

from ..hints import did_you_mean
from .entry import find_entry_file
from .errors import TaskError

BUNDLED_DIR = Path(__file__).resolve().parent.parent / "bundled_tasks"


def bundled_task_names() -> list[str]:
    """Names of the bundled task folders, sorted."""
    if not BUNDLED_DIR.is_dir():
        return []
    return sorted(p.name for p in BUNDLED_DIR.iterdir() if p.is_dir() and not p.name.startswith(("_", ".")))


def resolve_task_path(name_or_path: str | Path) -> Path:
    """A bundled task name (case-insensitive) or a path -> the task's entry file."""
    p = Path(name_or_path)
    if p.exists():
        return find_entry_file(p)
    for name in bundled_task_names():
        if name.lower() == str(name_or_path).lower():
            return find_entry_file(BUNDLED_DIR / name)
    raise TaskError(
        f"no task folder or bundled task named '{name_or_path}'{did_you_mean(p.name, bundled_task_names())}"
        f" (bundled: {', '.join(bundled_task_names()) or 'none'})",
        file=str(name_or_path),
    )
