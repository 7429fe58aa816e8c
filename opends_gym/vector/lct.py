"""The Lane Change Test for a native batch (`envs.lct.LaneChangeTestEnv`'s hooks over N envs).

Why: signs are revealed by their trigger boxes (`manipulateObject visible`), so each env
keeps the highest sign index revealed; the normative-path deviation, the reward and the
running MDEV accumulate per physics step as arrays, with the single env's formulas.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..envs.lct import LaneChangeTestEnv
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

    def _on_action(self, e: int, act: CompiledAction, trigger: int) -> None:
        if act.name == "manipulateObject":
            k = self.sign_of_model.get(str(act.args["object_id"]))
            if k is not None and act.args.get("visible"):
                self.revealed[e] = max(int(self.revealed[e]), k)
            return
        super()._on_action(e, act, trigger)

    def _norm_at(self, d: np.ndarray) -> np.ndarray:
        i = ((d - self.norm_d0) / self.norm_step).astype(np.int64)  # int(): towards zero
        last = len(self.norm) - 1
        return np.where(i < 0, self.norm[0], np.where(i >= last + 1, self.norm[-1], self.norm[np.clip(i, 0, last)]))

    def _on_physics_step(self, rows: np.ndarray, k: int, c: BatchControls) -> None:
        d = self.start_z - self.s.z
        dev = np.abs(self.lat - self._norm_at(d))
        mid = 0.5 * (dev + self.prev_dev)
        dd = d - self.prev_d
        area = self.area + mid * dd
        reward = self.step_reward + np.maximum(0.0, 1.0 - mid / self.scale) * dd
        if rows.all() and self.has_prev.all():  # the common case: no masks needed
            self.area, self.step_reward, self.prev_d, self.prev_dev = area, reward, d, dev
            return
        prev = rows & self.has_prev
        self.area = np.where(prev, area, self.area)
        self.step_reward = np.where(prev, reward, self.step_reward)
        self.prev_d = np.where(rows, d, self.prev_d)
        self.prev_dev = np.where(rows, dev, self.prev_dev)
        self.has_prev |= rows

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
        self.step_reward = np.zeros(self.n)
        r = np.where(terminated_task, r - self.off_road_penalty, r)
        return r - 10.0 * info["new_collisions"].astype(np.float64)

    def _task_info(self, info: dict[str, np.ndarray]) -> None:
        dist = np.where(self.has_prev, self.prev_d, 0.0)
        info["mean_deviation_m"] = np.where(dist > 0, self.area / np.where(dist > 0, dist, 1.0), 0.0)
