"""Natively batched vector envs (`vector_entry_point`) for the LCT, brake and platoon tests and
driving tasks with traffic (`OpenDS/DrivingTask-v0`, e.g. MotorwayTask; see `driving`).

`gymnasium.make_vec("OpenDS/LaneChangeTest-v0", num_envs=4096, vectorization_mode="vector_entry_point")`
returns a `NativeVectorEnv`: all envs in numpy arrays, the same results as the single env
for the same seeds and actions (see `opends_gym.vector.env`). Fast backend only.
"""

from __future__ import annotations

from typing import Any

from .env import NativeVectorEnv


def make_lane_change_test(num_envs: int, **kwargs: Any) -> Any:
    """The LCT's native batch; with `observation="driver_view"` its images drawn as one batch
    frame (`pixels.DriverViewVectorEnv`)."""
    from .lct import LctBatch

    if kwargs.get("observation") == "driver_view":
        from .pixels import DriverViewVectorEnv

        return DriverViewVectorEnv("OpenDS/LaneChangeTest-v0", LctBatch, num_envs, **kwargs)
    return NativeVectorEnv("OpenDS/LaneChangeTest-v0", LctBatch, num_envs, **kwargs)


def make_brake_reaction(num_envs: int, **kwargs: Any) -> NativeVectorEnv:
    from .platoon import BrakeBatch

    return NativeVectorEnv("OpenDS/BrakeReaction-v0", BrakeBatch, num_envs, **kwargs)


def make_driving_task(num_envs: int, **kwargs: Any) -> NativeVectorEnv:
    """A driving task's native batch (`driving.DrivingTaskBatch`); a task with a feature it does
    not model is refused, naming the feature and the vectorization mode that runs any task (this
    is also `gymnasium.make_vec`'s default mode for the id)."""
    from .driving import DrivingTaskBatch

    try:
        return NativeVectorEnv("OpenDS/DrivingTask-v0", DrivingTaskBatch, num_envs, **kwargs)
    except ValueError as e:
        raise ValueError(f"{e}; gymnasium.make_vec('OpenDS/DrivingTask-v0', ..., vectorization_mode='sync') runs any task") from None


def make_three_vehicle_platoon(num_envs: int, **kwargs: Any) -> NativeVectorEnv:
    from .platoon import PlatoonBatch

    return NativeVectorEnv("OpenDS/ThreeVehiclePlatoon-v0", PlatoonBatch, num_envs, **kwargs)


__all__ = ["NativeVectorEnv", "make_brake_reaction", "make_driving_task", "make_lane_change_test", "make_three_vehicle_platoon"]
