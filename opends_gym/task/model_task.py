"""`DrivingTask`: one frozen, validated view of a whole OpenDS task folder."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from .entry import EntryFile
from .errors import TaskWarning
from .model_interaction import Interaction
from .model_scenario import Scenario
from .model_scene import Model, ResetPoint, Scene
from .model_settings import Settings
from .model_taskxml import TaskSpec
from .values import IDENTITY, Rotation, Vec3


@dataclass(frozen=True)
class Pose:
    position_m: Vec3
    rotation: Rotation = IDENTITY

    @property
    def yaw_rad(self) -> float:
        return self.rotation.yaw_rad


@dataclass(frozen=True)
class DrivingTask:
    """Everything a driving task describes, in SI units, with references checked.

    Equality compares content only (not the folder, warnings or source lines), so a task
    saved with `save_task` and loaded again equals the original.
    """

    name: str
    entry: EntryFile
    scene: Scene
    scenario: Scenario
    interaction: Interaction
    settings: Settings
    task: TaskSpec | None = None
    folder: Path = field(default=Path("."), compare=False)
    warnings: tuple[TaskWarning, ...] = field(default=(), compare=False)

    @property
    def car_model(self) -> Model:
        """The scene model the driver's car is built from (checked to exist at load)."""
        model = self.scene.model(self.scenario.driver.car.ref)
        assert model is not None
        return model

    @property
    def start_pose(self) -> Pose:
        """Where the ego car starts: the pose of its scene model, as in OpenDS."""
        m = self.car_model
        return Pose(m.translation_m or (0.0, 0.0, 0.0), m.rotation)

    def reset_poses(self) -> dict[str, Pose]:
        """Reset points of the car (scenario refs and inline ones) by id, then the scene's."""
        out: dict[str, Pose] = {}
        for rp in self.scenario.driver.car.reset_points:
            if rp.ref:
                target: ResetPoint | None = self.scene.reset_point(rp.ref)
                if target is not None:
                    out[rp.ref] = Pose(target.translation_m, target.rotation)
            elif rp.translation_m is not None:
                out[rp.id or f"reset{len(out)}"] = Pose(rp.translation_m, rp.rotation or IDENTITY)
        for r in self.scene.reset_points:
            out.setdefault(r.id, Pose(r.translation_m, r.rotation))
        return out

    @property
    def open_drive_path(self) -> Path | None:
        return self.folder / self.entry.open_drive if self.entry.open_drive else None

    def files_sha256(self) -> str:
        """A hash of the task's files as read from disk, to pin recordings to a task version."""
        h = hashlib.sha256()
        for key in ("scene", "scenario", "interaction", "settings", "task", "openDrive"):
            name = self.entry.layer_file(key)
            if not name:
                continue
            p = self.folder / name
            h.update(key.encode())
            h.update(p.read_bytes() if p.is_file() else b"")
        return h.hexdigest()
