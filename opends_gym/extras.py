"""Optional dependencies (pip extras), imported through one helper.

Why: the core install carries only what the environments need; the rest is an extra
(`pip install "opends-gym[rl]"`). A missing one must say which extra to install in one line,
not end in a `ModuleNotFoundError` traceback from deep inside a feature.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from .errors import UserError

# extra -> (what needs it, the modules it provides): the extras of pyproject.toml
EXTRAS: dict[str, tuple[str, tuple[str, ...]]] = {
    "rl": ("stable-baselines3 policies and training", ("stable_baselines3", "torch", "tqdm", "rich")),
    "bullet": ('the pybullet physics backend (physics="bullet")', ("pybullet", "pybullet_utils")),
    "report": ("the PDF report", ("matplotlib",)),
    "can": ("the CAN bus input", ("can", "cantools")),
    "video": ("video recording (Gymnasium's RecordVideo)", ("moviepy",)),
    "bench": ("the highway-env comparison benchmark", ("highway_env",)),
    "cluster": ("Ray RLlib training", ("ray", "tensorboardX")),
    "study": ("the study runner's table, statistics and report", ("statsmodels", "scipy", "pandas", "pyarrow", "matplotlib")),
    "data": ("Minari datasets (opends-gym export --minari, train bc)", ("minari",)),
}


class MissingExtra(UserError):
    """A feature's optional dependency is not installed; the message names the pip command."""

    def __init__(self, extra: str, module: str, feature: str | None = None) -> None:
        self.extra = extra
        self.module = module
        what = feature or EXTRAS[extra][0]
        super().__init__(f"{what} needs the '{extra}' extra: pip install \"opends-gym[{extra}]\"")


def require(extra: str, module: str, feature: str | None = None) -> ModuleType:
    """Import `module` (part of `extra`), or raise MissingExtra naming the install command.

    `feature` names what needs it in the message (default: the extra's description).
    """
    if extra not in EXTRAS:
        raise ValueError(f"unknown extra {extra!r}; known: {', '.join(EXTRAS)}")
    try:
        return importlib.import_module(module)
    except ImportError as e:
        missing = getattr(e, "name", None) or module
        # only the module itself (or one of its own dependencies) missing means "install the extra";
        # a broken install of a present package is a real error and keeps its traceback
        if missing.split(".")[0] not in (module.split(".")[0], *_dependency_roots(extra)):
            raise
        raise MissingExtra(extra, module, feature) from e


def _dependency_roots(extra: str) -> tuple[str, ...]:
    return tuple(m.split(".")[0] for m in EXTRAS[extra][1])


def extra_of_module(top_level: str) -> str | None:
    """The extra that installs a top-level module (`torch` -> `rl`), or None for none of ours."""
    return next((extra for extra, (_, modules) in EXTRAS.items() if top_level in (m.split(".")[0] for m in modules)), None)
