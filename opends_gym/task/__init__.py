"""OpenDS driving tasks: load, validate and save the four-file task format.

>>> from opends_gym.task import load_task
>>> task = load_task("tasks/LaneChangeTest")            # doctest: +SKIP
"""

from .actions_catalog import ACTIONS, ActionSpec, ParamSpec, action_spec
from .errors import TaskError, TaskWarning
from .loader import load_task
from .missing_assets import MissingAssetWarning
from .model_task import DrivingTask, Pose
from .writer import save_task

__all__ = [
    "ACTIONS",
    "ActionSpec",
    "DrivingTask",
    "MissingAssetWarning",
    "ParamSpec",
    "Pose",
    "TaskError",
    "TaskWarning",
    "action_spec",
    "load_task",
    "save_task",
]
