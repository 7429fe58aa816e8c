"""One-line summaries of loaded tasks (what `opends-gym validate` prints)."""

from __future__ import annotations

from dataclasses import dataclass

from .model_task import DrivingTask


@dataclass(frozen=True)
class TaskSummary:
    name: str
    models: int
    triggers: int
    actions: int
    traffic_vehicles: int
    pedestrians: int
    lanes: int
    ideal_tracks: int
    warnings: int
    road: str = "none"  # where the ego's road comes from (X-band `lanes`, or a `sim.lane_sources` source)
    road_lanes: int = 0  # the lanes known across it (0: a line to follow, lanes unknown)

    def line(self) -> str:
        return (
            f"models={self.models} triggers={self.triggers} actions={self.actions} "
            f"traffic={self.traffic_vehicles} pedestrians={self.pedestrians} lanes={self.lanes} "
            f"ideal_tracks={self.ideal_tracks} road={self.road} road_lanes={self.road_lanes} warnings={self.warnings}"
        )


def summarize(task: DrivingTask, road: str = "none", road_lanes: int = 0) -> TaskSummary:
    """The counts of a loaded task; `road`, `road_lanes`: the ego's road as the simulation
    builds it (`sim.lane_sources.road_summary`, which this layer cannot import)."""
    sc = task.scenario
    return TaskSummary(
        name=task.name,
        models=len(task.scene.models),
        triggers=len(task.interaction.triggers),
        actions=len(task.interaction.all_actions()),
        traffic_vehicles=len(sc.vehicles) + len(sc.od_vehicles),
        pedestrians=len(sc.pedestrians),
        lanes=len(sc.road.lanes),
        ideal_tracks=len(sc.driver.ideal_tracks),
        warnings=len(task.warnings),
        road=road,
        road_lanes=road_lanes,
    )
