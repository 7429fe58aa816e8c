"""`OpenDS/ReactionTest-v0`: OpenDS's five-lane sign reaction test (the corpus task)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from ..metrics.reaction import summarize_reactions
from ..task import DrivingTask, load_task
from .base import OpenDSEnv
from .config import EnvConfig

_ELEMENT = re.compile(r"_ContainerElement(\d+)$")


@dataclass(frozen=True)
class ReactionTestConfig(EnvConfig):
    task: str = "ReactionTest"
    max_episode_s: float = 400.0
    reward_correct: float = 1.0
    reward_wrong: float = -1.0
    reward_lane_keeping: float = 0.01


@dataclass(frozen=True)
class _Sign:
    model_id: str
    kind: float  # 1 brake, 2 lane change
    lane: int  # the lane the panel hangs over (its ContainerElement index)
    z_m: float


class ReactionTestEnv(OpenDSEnv):
    """OpenDS's ReactionTest (from OpenDS-CTS, bundled in `tasks/ReactionTest`): drive in
    the centre of five lanes at up to 60 km/h (the car keeps at least 20 km/h off the
    brake); trigger boxes reveal a sign over one lane, either "Brake" (slow from >= 50 to
    <= 40 km/h and hold 2 s) or "Lane change" (move to the lane under the sign and hold
    2 s), scored by OpenDS's brake and lane-change reaction timers (7000 ms / 117 m
    limits).

    ## Action space
    As `DrivingTaskEnv` (default `continuous` [steering, pedal]).

    ## Observation space
    `kinematics` plus `sign_kind` (0 none, 1 brake, 2 lane change), `sign_lane_offset_m`
    (lateral position of the sign's lane centre relative to the car, + left) and
    `sign_distance_m` (to the revealed sign, 0 when none).

    ## Reward
    `reward_correct` per correct reaction, `reward_wrong` per failure or miss, plus
    `reward_lane_keeping` per step while in a lane; -10 per collision.

    ## Episode end
    Terminated when the task's end trigger pauses the simulation (after all 20 trials),
    on a collision (`on_collision`, see `opends_gym.envs.collision`) or off the road
    (`on_road_exit`, see `opends_gym.envs.road_exit`);
    truncated after `max_episode_s`.

    ## Info
    `OpenDSEnv`'s keys (reaction_result / reaction_time_s each time a timer scores);
    `episode_metrics` adds per reaction group (Brake, LaneChange): `<group>_n`,
    `<group>_correct`, `<group>_failures`, `<group>_misses`, `<group>_mean_rt_s`, and the
    exposure (`OpenDSEnv`'s; stimuli_presented counts the signs revealed).

    ## Version history
    v0: initial release.
    """

    config_class = ReactionTestConfig
    stimulus_names = ("sign_kind", "sign_lane_offset_m", "sign_distance_m")

    def _make_task(self) -> DrivingTask:
        assert isinstance(self.config, ReactionTestConfig)
        return load_task(self.config.task)

    def _setup(self) -> None:
        self.signs: list[_Sign] = []
        for objs in self.world.objects.by_id.values():
            for o in objs:
                m = _ELEMENT.search(o.id)
                if not m:
                    continue
                key = self.task.scene.models[o.index].key
                kind = 1.0 if "Brake" in key else 2.0 if "LaneChange" in key else 0.0
                if kind:
                    self.signs.append(_Sign(o.id, kind, int(m.group(1)), o.position[2]))
        self.signs.sort(key=lambda s: -s.z_m)
        self._objs = {s.model_id: self.world.objects.by_id[s.model_id][0] for s in self.signs}
        self.half_road = max(abs(b) for lane in self.world.road.lanes for b in (lane.x_min, lane.x_max))

    def _active_sign(self) -> _Sign | None:
        z = self.world.ego.state.z
        for s in self.signs:
            if self._objs[s.model_id].visible and s.z_m < z + 5.0:
                return s
        return None

    def _stimulus(self) -> list[float]:
        sign = self._active_sign()
        if sign is None:
            return [0.0, 0.0, 0.0]
        s = self.world.ego.state
        lat = self.guide.locate(s.x, s.z).lateral_m
        lane_lat = self.guide.lane_laterals_m[sign.lane] if sign.lane < len(self.guide.lane_laterals_m) else lat
        return [sign.kind, lane_lat - lat, max(0.0, s.z - sign.z_m)]

    def _reward(self, info: dict[str, Any]) -> float:
        cfg = self.config
        assert isinstance(cfg, ReactionTestConfig)
        r = cfg.reward_lane_keeping if info["lane_index"] >= 0 else 0.0
        if info["reaction_result"] == 1:
            r += cfg.reward_correct
        elif info["reaction_result"] < 0:
            r += cfg.reward_wrong
        return r - 10.0 * float(info["new_collisions"])

    def _off_road_at(self, lateral_m: float) -> bool:
        return abs(lateral_m) > self.half_road + self.config.off_road_margin_m  # (the lanes run along Z: |lateral| = |X|)

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        self._shown: set[str] = set()

    def _task_info(self, info: dict[str, Any]) -> None:
        self._shown.update(sid for sid, o in self._objs.items() if o.visible)

    def _stimuli_presented(self) -> int:
        """Signs revealed."""
        return len(self._shown)

    def _episode_metrics(self) -> dict[str, float]:
        reactions = getattr(self.world.triggers, "reactions", ())
        summary = summarize_reactions((r.group, r.result, r.reaction_time_s) for r in reactions)
        out: dict[str, float] = {}
        for group in ("Brake", "LaneChange"):
            g = summary.get(group)
            out[f"{group}_n"] = float(g.n) if g else 0.0
            out[f"{group}_correct"] = float(g.correct) if g else 0.0
            out[f"{group}_failures"] = float(g.failures) if g else 0.0
            out[f"{group}_misses"] = float(g.misses) if g else 0.0
            out[f"{group}_mean_rt_s"] = g.mean_rt_s if g else math.nan
        return out
