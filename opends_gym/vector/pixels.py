"""`DriverViewVectorEnv`: the native Lane Change Test batch with `driver_view` image observations.

Why: an RL trainer on pixels steps many envs at once. A `SyncVectorEnv` of single image envs
pays the single env's Python simulation step (~95 us of CPU) plus a Panda3D frame per env and step;
here the simulation is the native batch's (`NativeVectorEnv`, compiled, microseconds per env)
and the N driver views are N display regions of one offscreen buffer drawn by one
`renderFrame` and read once (`render.batch_view.BatchDriverView`).

`gymnasium.make_vec("OpenDS/LaneChangeTest-v0", num_envs=N, vectorization_mode="vector_entry_point",
observation="driver_view")` returns it. Each env's image is the single env's driver view
(`gymnasium.make(id, observation="driver_view")` with the same seed and actions) pixel for
pixel (tested); rewards, flags and info are the native batch's, which are the single env's.

How: one render-only `World` of the task per env holds what the view draws; before each frame
it gets the batch's car pose (x, z, yaw), simulation time and revealed signs (the LCT's only
changing scene: its trigger boxes reveal sign pairs in order along the road, never hide them;
`LctBatch.revealed` is the highest sign index revealed, and every sign before it is shown: a
sign a car passed beside its trigger box lies 100 m or more behind the car by the time the next
one shows, out of the driver's view). These Worlds are never stepped.
Supported: the LCT's native batch in this process (not `processes=`); the other tasks' image
observations run in `vectorization_mode="sync"`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..sim.world import World
from .env import NativeVectorEnv


class DriverViewVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """The native LCT batch whose observations are the envs' driver views; see the module docstring."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, env_id: str, batch_cls: type, num_envs: int, **kwargs: Any) -> None:
        from ..render.batch_view import BatchDriverView
        from .lct import LctBatch

        if batch_cls is not LctBatch:
            raise ValueError(f"driver_view observations in the native batch are the LCT's; use vectorization_mode='sync' for {env_id}")
        if kwargs.get("processes") not in (None, 1):
            raise ValueError("the driver_view native batch renders in this process: leave out processes=")
        self.native = NativeVectorEnv(env_id, batch_cls, num_envs, **{**kwargs, "observation": "kinematics"})
        self.num_envs = num_envs
        self._cores: list[tuple[slice, Any]] = [(sl, shard.core) for sl, shard in zip(self.native._slices, self.native.shards)]  # type: ignore[union-attr]
        template = self._cores[0][1].template
        cfg = template.config
        width, height = int(cfg.image_width), int(cfg.image_height)
        self.worlds = [World(template.world.task, template.world.config) for _ in range(num_envs)]
        self._ego_y = float(template.world.ego.state.y)
        ids = {o.id: o for o in template.world.objects.objects}
        for w in self.worlds:
            w.ego.state.y = self._ego_y
        # per sign index: its (left, right) objects' positions in `World.objects.objects`
        index = {o.id: i for i, o in enumerate(self.worlds[0].objects.objects)}
        self._signs = [
            [index[f"LCT_Sign{spec.index:02d}_{side}"] for side in ("Left", "Right") if f"LCT_Sign{spec.index:02d}_{side}" in ids]
            for spec in template.sign_specs
        ]
        self._shown = np.full(num_envs, -2, dtype=np.int64)  # the highest sign index each render World shows
        self.view = BatchDriverView(self.worlds, width, height)
        self.single_observation_space = gym.spaces.Box(0, 255, shape=(height, width, 3), dtype=np.uint8)
        self.single_action_space = self.native.single_action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = self.native.action_space
        self.render_mode = None

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed if isinstance(seed, int) else None)
        _, info = self.native.reset(seed=seed, options=options)
        return self._frames(), info

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        _, reward, terminated, truncated, info = self.native.step(actions)
        return self._frames(), reward, terminated, truncated, info

    def _frames(self) -> np.ndarray:
        """Copy the batch's state into the render Worlds, then draw them all in one frame."""
        for sl, core in self._cores:
            s = core.s
            xs, zs, yaws, ts, revealed = s.x.tolist(), s.z.tolist(), s.yaw.tolist(), core.t.tolist(), core.revealed.tolist()
            for j, w in enumerate(self.worlds[sl]):
                st = w.ego.state
                st.x, st.z, st.yaw = xs[j], zs[j], yaws[j]
                w.t_s = ts[j]
                e = sl.start + j
                if revealed[j] != self._shown[e]:
                    self._show_signs(w, revealed[j])
                    self._shown[e] = revealed[j]
        return self.view.render()

    def _show_signs(self, world: World, revealed: int) -> None:
        objects = world.objects.objects
        for k, rows in enumerate(self._signs):
            for i in rows:
                objects[i].visible = k <= revealed

    def close_extras(self, **kwargs: Any) -> None:
        self.view.close()
        self.native.close()
