"""`NativeVectorEnv`: N OpenDS envs of one id as one `gymnasium.vector.VectorEnv`.

Why: `SyncVectorEnv` steps N single envs in a Python loop; this steps them together as
numpy arrays (see `core.BatchCore`), for the Lane Change Test, the brake reaction test and
the platoon test on the fast backend. `gymnasium.make_vec(id, num_envs=N,
vectorization_mode="vector_entry_point", **kwargs)` returns it.

Same results as the single env: for seeds s_i and the same actions, env i's observations,
rewards, terminated/truncated flags, info numbers and `episode_metrics` equal those of
`gymnasium.make(id, **kwargs)` reset with seed s_i and stepped with those actions, bit for
bit (tested). Python's `math` functions that numpy computes differently are taken from the
C library or re-implemented (`libm`).

Vector API: autoreset mode NEXT_STEP (Gymnasium's default; the step after an episode ends
resets that env, with reward 0 and both flags False), seeding as `SyncVectorEnv`
(`reset(seed=s)` seeds env i with s + i, a list seeds each env, later autoresets continue
each env's generator), info as a dict of arrays with `_key` masks and `episode_metrics` as
a nested dict on the steps where episodes end. Differences: the `events` info key (the
per-step event log) is not produced, nor rendering; `record_metrics=False` skips the
per-step traces (and `episode_metrics`) to save memory at large N.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..envs.observations import EGO_NAMES, VEHICLE_NAMES
from .core import BatchCore


class NativeVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """N envs of one OpenDS id stepped as arrays; see the module docstring."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, env_id: str, batch_cls: type[BatchCore], num_envs: int, record_metrics: bool = True, **kwargs: Any) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, not {num_envs}")
        if kwargs.get("physics", "fast") != "fast":
            raise ValueError(
                f"the native batch of {env_id} simulates physics='fast' only; for physics={kwargs['physics']!r} use "
                f"gymnasium.make_vec({env_id!r}, num_envs={num_envs}, vectorization_mode='sync' (or 'async'), physics=...)"
            )
        if kwargs.pop("render_mode", None) is not None:
            raise ValueError("the native batch does not render; use vectorization_mode='sync' to render")
        kwargs.pop("max_episode_steps", None)
        template: Any = gym.make(env_id, disable_env_checker=True, **kwargs).unwrapped
        if template.config.observation != "kinematics":
            raise ValueError(f"the native batch supports the kinematics observation, not {template.config.observation!r}")
        self.env_id = env_id
        self.num_envs = num_envs
        self.core = batch_cls(template, num_envs, record_metrics)  # type: ignore[arg-type]
        self.single_observation_space = template.observation_space
        self.single_action_space = template.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.render_mode = None
        self._k = int(template.config.nearby_vehicles)
        self._obs_size = len(EGO_NAMES) + self._k * len(VEHICLE_NAMES) + len(template.stimulus_names)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._started = False

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed if isinstance(seed, int) else None)
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"reset(seed=list) needs {self.num_envs} seeds, got {len(seeds)}")
        if options is not None and "reset_mask" in options:
            raise ValueError("reset_mask belongs to the DISABLED autoreset mode; this env autoresets on the next step")
        idx = np.arange(self.num_envs)
        self.core.reset_rows(idx, seeds)
        self._autoreset[:] = False
        self._started = True
        return self._observe(), self._info_dict(self.core.info(), np.zeros(self.num_envs, dtype=bool))

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        core = self.core
        resetting = self._autoreset.copy()
        stepping = ~resetting
        reward, terminated, truncated, values = core.step_rows(actions, stepping)
        if resetting.any():
            core.reset_rows(np.flatnonzero(resetting), None)
            fresh = core.info()
            values = {k: np.where(resetting, fresh[k], v) for k, v in values.items()}
        ended = terminated | truncated
        info = self._info_dict(values, ended)
        self._autoreset = ended
        reward = np.where(stepping, reward, 0.0)
        return self._observe(), reward, terminated, truncated, info

    def close_extras(self, **kwargs: Any) -> None:
        self.core.template.close()

    # ------------------------------------------------------------------ outputs
    def _observe(self) -> np.ndarray:
        """The kinematics observation of every env (float32, as the single env's)."""
        c = self.core
        s = c.s
        out = np.zeros((self.num_envs, self._obs_size))
        heading = c.guide.road_heading
        out[:, 0] = s.u
        out[:, 1] = (s.yaw - heading + np.pi) % (2.0 * np.pi) - np.pi
        out[:, 2] = c.offset
        out[:, 3] = c.lat
        out[:, 4] = c.lane
        out[:, 5] = s.steer_in
        out[:, 6] = s.r
        base = len(EGO_NAMES)
        vehicles = c.vehicle_slots(self._k) if self._k else None
        if vehicles is not None:
            out[:, base : base + vehicles.shape[1]] = vehicles
        stim = c._stimulus()
        if stim.shape[1]:
            out[:, base + self._k * len(VEHICLE_NAMES) :] = stim
        return out.astype(np.float32)

    def _info_dict(self, values: dict[str, np.ndarray], ended: np.ndarray) -> dict[str, Any]:
        info: dict[str, Any] = {}
        full = np.ones(self.num_envs, dtype=bool)
        for k, v in values.items():
            info[k] = v
            info[f"_{k}"] = full
        if ended.any() and self.core.record_metrics:
            for e in np.flatnonzero(ended).tolist():
                info = self._add_info(info, {"episode_metrics": self.core.episode_metrics(e)}, e)
        return info
