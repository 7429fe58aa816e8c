"""Environment ids, registered once per process (idempotent, string entry points).

Why: SB3's SubprocVecEnv starts workers with forkserver/spawn; they never run our
registration unless `gymnasium.make("opends_gym:OpenDS/...")` imports the package, so
registration must happen on import and tolerate running twice.
"""

from __future__ import annotations

from typing import Any

import gymnasium

ENVS: dict[str, str] = {
    "OpenDS/DrivingTask-v0": "opends_gym.envs.driving_task:DrivingTaskEnv",
    "OpenDS/LaneChangeTest-v0": "opends_gym.envs.lct:LaneChangeTestEnv",
    "OpenDS/ReactionTest-v0": "opends_gym.envs.reaction_test:ReactionTestEnv",
    "OpenDS/ConTRe-v0": "opends_gym.envs.contre:ConTReEnv",
    "OpenDS/BrakeReaction-v0": "opends_gym.envs.brake:BrakeReactionEnv",
    "OpenDS/ThreeVehiclePlatoon-v0": "opends_gym.envs.platoon:ThreeVehiclePlatoonEnv",
}

# natively batched vector envs (`gymnasium.make_vec(id, n, vectorization_mode="vector_entry_point")`)
VECTOR_ENVS: dict[str, str] = {
    "OpenDS/DrivingTask-v0": "opends_gym.vector:make_driving_task",
    "OpenDS/LaneChangeTest-v0": "opends_gym.vector:make_lane_change_test",
    "OpenDS/BrakeReaction-v0": "opends_gym.vector:make_brake_reaction",
    "OpenDS/ThreeVehiclePlatoon-v0": "opends_gym.vector:make_three_vehicle_platoon",
}


def register_envs() -> None:
    for env_id, entry_point in ENVS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point, vector_entry_point=VECTOR_ENVS.get(env_id), disable_env_checker=False)


def lookup_env_id(target: str) -> str | None:
    """The registered id `target` names: the id itself or a short name (`LaneChangeTest`)."""
    register_envs()
    for candidate in (target, f"OpenDS/{target}", f"OpenDS/{target}-v0"):
        if candidate in gymnasium.registry:
            return candidate
    return None


def resolve_env_id(target: str) -> tuple[str, dict[str, Any]]:
    """An env id for `target`: a registered id, a short name (`LaneChangeTest`), or else a task
    folder or entry file for the generic `OpenDS/DrivingTask-v0` (returned as its `task` kwarg)."""
    env_id = lookup_env_id(target)
    return (env_id, {}) if env_id is not None else ("OpenDS/DrivingTask-v0", {"task": target})
