"""`DrivingTask`: one frozen, validated view of a whole OpenDS task folder."""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

from .entry import EntryFile
from .errors import TaskWarning
from .model_interaction import Interaction
from .model_scenario import Scenario
from .model_scene import Model, Point, ResetPoint, Scene
from .model_settings import Settings
from .model_taskxml import TaskSpec
from .values import IDENTITY, Rotation, Vec3, car_rotation


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
        """Where the ego car starts: the pose of its scene model (OpenDS's
        `ScenarioLoader.processSceneCar`) with the heading OpenDS's `Car.setRotation` gives
        it (the file's angle negated, see `values.car_rotation`), or, with the autopilot enabled, its start
        waypoint facing the next one (the `FollowBox` OpenDS's `SteeringCar` builds with
        setToStartWayPoint = autopilot on moves the car there, `FollowBox.getHeadingAtWP`)."""
        m = self.car_model
        pose = Pose(m.translation_m or (0.0, 0.0, 0.0), car_rotation(m.rotation))
        return _autopilot_start(self, pose) or pose

    def reset_poses(self) -> dict[str, Pose]:
        """Reset points of the car (scenario refs and inline ones) by id, then the scene's,
        with the heading `Car.setRotation` gives the car there (see `start_pose`)."""
        out: dict[str, Pose] = {}
        for rp in self.scenario.driver.car.reset_points:
            if rp.ref:
                target: ResetPoint | None = self.scene.reset_point(rp.ref)
                if target is not None:
                    out[rp.ref] = Pose(target.translation_m, car_rotation(target.rotation))
            elif rp.translation_m is not None:
                out[rp.id or f"reset{len(out)}"] = Pose(rp.translation_m, car_rotation(rp.rotation or IDENTITY))
        for r in self.scene.reset_points:
            out.setdefault(r.id, Pose(r.translation_m, car_rotation(r.rotation)))
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


def _autopilot_start(task: DrivingTask, pose: Pose) -> Pose | None:
    """The start waypoint of an enabled autopilot and the heading towards the waypoint after it."""
    ap = task.scenario.driver.car.auto_pilot
    if ap is None or not ap.enabled or not ap.start_way_point:
        return None
    points = {g.id: g.translation_m for g in task.scene.geometries if isinstance(g, Point)}

    def where(translation: Vec3 | None, ref: str) -> Vec3 | None:
        return translation if translation is not None else points.get(ref)

    chain: list[Vec3 | None] = []
    if ap.way_points:  # Gen A 4.x: its own list; the next one wraps on a cyclic path
        ids = [w.id for w in ap.way_points]
        if ap.start_way_point not in ids:
            return None
        k = ids.index(ap.start_way_point)
        after = k + 1 if k + 1 < len(ids) else (0 if ap.path_is_cycle else None)
        chain = [where(ap.way_points[k].translation_m, ap.way_points[k].ref)]
        if after is not None:
            chain.append(where(ap.way_points[after].translation_m, ap.way_points[after].ref))
    else:  # Gen B: a road waypoint; the first segment leaving it gives the direction
        road = {w.key: w for w in task.scenario.road.way_points.points} if task.scenario.road.way_points else {}
        wp = road.get(ap.start_way_point)
        if wp is None:
            return None
        chain = [where(wp.translation_m, wp.ref)]
        segs = task.scenario.road.segments.items if task.scenario.road.segments else ()
        seg = next((g for g in segs if g.from_wp == ap.start_way_point and not g.jump), None)
        if seg is not None:
            nxt = road.get((seg.via or (seg.to_wp,))[0])
            if nxt is not None:
                chain.append(where(nxt.translation_m, nxt.ref))
    start = chain[0]
    if start is None:
        return None
    if len(chain) < 2 or chain[1] is None:
        return Pose(start, pose.rotation)
    dx, dz = chain[1][0] - start[0], chain[1][2] - start[2]
    if dx == 0.0 and dz == 0.0:
        return Pose(start, pose.rotation)
    yaw = math.atan2(-dx, -dz)  # jME heading: 0 faces -Z, + turns left
    return Pose(start, Rotation.from_euler_deg(0.0, math.degrees(yaw), 0.0))
