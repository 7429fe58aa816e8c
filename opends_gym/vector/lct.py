"""The Lane Change Test for a native batch (`envs.lct.LaneChangeTestEnv`'s hooks over N envs).

Why: signs are revealed by their trigger boxes (`manipulateObject visible`), so each env
keeps the highest sign index revealed; the normative-path deviation, the reward and the
running MDEV accumulate per physics step as arrays, with the single env's formulas.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..envs.lct import LaneChangeTestEnv
from ..sim.jit import kernel
from ..sim.triggers.core import CompiledAction
from .actions import BatchControls
from .core import BatchCore


class LctBatch(BatchCore):
    handled_actions = frozenset({"setupLaneChangeReactionTimer", "manipulateObject"})

    def __init__(self, template: LaneChangeTestEnv, n: int, record_metrics: bool = True) -> None:
        super().__init__(template, n, record_metrics)
        env = template
        cfg: Any = env.config
        self.norm = np.asarray(env._norm, dtype=np.float64)
        self.norm_d0, self.norm_step = env._norm_d0, env._norm_step
        self.sign_of_model = {}
        for k, spec in enumerate(env.sign_specs):
            for side in ("Left", "Right"):
                self.sign_of_model[f"LCT_Sign{spec.index:02d}_{side}"] = k
        self.sign_z = np.array([s.z_m for s in env.sign_specs] + [0.0])
        self.sign_lane = np.array([s.to_lane for s in env.sign_specs] + [env.initial_lane], dtype=np.int64)
        self.lane_lat = np.asarray(env.lane_laterals, dtype=np.float64)
        self.scale = cfg.reward_deviation_scale_m
        self.reward_scale = cfg.reward_scale
        self.off_road_penalty = cfg.off_road_penalty
        self.off_road_limit = env.half_road + cfg.off_road_margin_m
        self.revealed = np.full(n, -1, dtype=np.int64)  # highest sign index revealed (the visible one shown)
        self.area = np.zeros(n)
        self.step_reward = np.zeros(n)
        self.has_prev = np.zeros(n, dtype=bool)
        self.prev_d = np.zeros(n)
        self.prev_dev = np.zeros(n)

    def _reset_task(self, idx: np.ndarray) -> None:
        self.revealed[idx] = -1
        self.area[idx] = 0.0
        self.step_reward[idx] = 0.0
        self.has_prev[idx] = False

    def _on_action_rows(self, es: np.ndarray, act: CompiledAction, trigger: int) -> None:
        if act.name == "manipulateObject":
            k = self.sign_of_model.get(str(act.args["object_id"]))
            if k is not None and act.args.get("visible"):
                self.revealed[es] = np.maximum(self.revealed[es], k)
            return
        super()._on_action_rows(es, act, trigger)

    def _on_physics_step(self, rows: np.ndarray, k: int, c: BatchControls) -> None:
        lct_measures(self.s.z, self.lat, rows, self.start_z, self.norm, self.norm_d0, self.norm_step, self.scale, self.has_prev,
                     self.prev_d, self.prev_dev, self.area, self.step_reward)  # fmt: skip

    def _stimulus(self) -> np.ndarray:
        z = self.s.z
        r = self.revealed
        on = r >= 0
        lane = self.sign_lane[np.where(on, r, -1)]
        distance = np.where(on, np.maximum(0.0, z - self.sign_z[r]), 0.0)
        visible = np.where(on & (distance > 0.0), 1.0, 0.0)
        return np.stack([visible, self.lane_lat[lane] - self.lat, distance], axis=1)

    def _task_terminated(self) -> np.ndarray:
        return np.abs(self.lat) > self.off_road_limit

    def _reward(self, info: dict[str, np.ndarray], terminated_task: np.ndarray) -> np.ndarray:
        r = self.reward_scale * self.step_reward
        self.step_reward[:] = 0.0
        r = np.where(terminated_task, r - self.off_road_penalty, r)
        return r - 10.0 * info["new_collisions"].astype(np.float64)

    def _task_info(self, info: dict[str, np.ndarray]) -> None:
        dist = np.where(self.has_prev, self.prev_d, 0.0)
        info["mean_deviation_m"] = np.where(dist > 0, self.area / np.where(dist > 0, dist, 1.0), 0.0)


@kernel
def lct_measures(z: np.ndarray, lat: np.ndarray, rows: np.ndarray, start_z: float, norm: np.ndarray, d0: float, step: float,
                 scale: float, has_prev: np.ndarray, prev_d: np.ndarray, prev_dev: np.ndarray, area: np.ndarray,
                 reward: np.ndarray) -> None:  # fmt: skip
    """`LaneChangeTestEnv._on_physics_step` per env of `rows`: the deviation from the normative
    path (sampled every `step` metres from `d0`) at the distance driven, the area between the
    two paths (trapezoids) and the reward's share of the step (m)."""
    for e in range(len(z)):
        if not rows[e]:
            continue
        d = start_z - z[e]
        i = int((d - d0) / step)  # int(): towards zero
        ideal = norm[0] if i < 0 else norm[len(norm) - 1] if i >= len(norm) else norm[i]
        dev = abs(lat[e] - ideal)
        if has_prev[e]:
            mid = 0.5 * (dev + prev_dev[e])
            dd = d - prev_d[e]
            area[e] = area[e] + mid * dd
            share = 1.0 - mid / scale
            reward[e] = reward[e] + (share if share > 0.0 else 0.0) * dd
        prev_d[e], prev_dev[e], has_prev[e] = d, dev, True
