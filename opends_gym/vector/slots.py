"""Drive each env of a native batch with its own Python agent: `SlotBatch` and `BatchSlot`.

Why: a driver model (the virtual participant of `drivers.participant`) reads its env through
`drivers.percept.perceive` and answers with `drivers.intent.to_action`. A `BatchSlot` is env
`index` of a batch seen as such an env: `perceive` reads its Percept from the batch's arrays
(the same Percept the single env gives in the same state), so one participant model drives
both paths while the batch steps the physics, triggers and metrics in compiled code.

`SlotBatch` steps the batch's core directly (`BatchCore.reset_rows`, `step_rows`,
`episodes_metrics`): an env whose episode ended stops stepping and can be reset alone with
the next trial's seed, so a stream of trials keeps every slot busy. Only the Lane Change
Test's batch has a slot reader (`supports`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from .core import BatchCore
from .shards import LocalShard

NATIVE_IDS = ("OpenDS/LaneChangeTest-v0",)  # batches that `perceive` reads (drivers.percept._read_native_lct)


class _SlotWorld:
    """The constants a driver reads of `env.unwrapped.world` (time step, car spec and car
    block: the rule driver's pedal map is read off the car model)."""

    def __init__(self, world: Any) -> None:
        self.dt_s = world.dt_s
        self.ego = _SlotEgo(world.ego.spec, world.ego.car)


class _SlotEgo:
    def __init__(self, spec: Any, car: Any) -> None:
        self.spec = spec
        self.car = car


class BatchSlot:
    """Env `index` of `batch` as a driver model sees an env (`unwrapped`, `world`, `guide`,
    `act_type`, `config`); `perceive` reads it through `drivers.percept`'s slot reader."""

    native_slot = True

    def __init__(self, batch: BatchCore, index: int) -> None:
        tpl: Any = batch.template
        self.batch = batch
        self.index = index
        self.guide = tpl.guide
        self.act_type = tpl.act_type
        self.config = tpl.config
        self.world = _SlotWorld(tpl.world)

    @property
    def unwrapped(self) -> BatchSlot:
        return self

    def state(self) -> tuple[float, float, float, float, float, float, int]:
        """(t, x, z, yaw, u, r, revealed sign) of this env now, as Python numbers (from the
        batch's per-step snapshot when `SlotBatch` took one, else from its arrays)."""
        snap = getattr(self.batch, "slot_snapshot", None)
        if snap is not None:
            return snap[self.index]  # type: ignore[no-any-return]
        b: Any = self.batch
        s, e = b.s, self.index
        return float(b.t[e]), float(s.x[e]), float(s.z[e]), float(s.yaw[e]), float(s.u[e]), float(s.r[e]), int(b.revealed[e])


def supports(env_id: str, env_args: dict[str, Any]) -> str | None:
    """Why trials of `env_id` with `env_args` cannot run on a slot batch, or None when they can."""
    if env_id not in NATIVE_IDS:
        return f"{env_id} has no native batch that drivers can read"
    if env_args.get("physics", "fast") != "fast":
        return "the native batch simulates physics='fast' only"
    if env_args.get("action", "continuous") != "continuous":
        return "driver models drive a native slot with the continuous action only"
    return None


class SlotBatch:
    """`n` envs of `env_id` (options `env_args`, `on_road_exit` terminate) stepped together;
    `reset(e, seed)` one env, `step(actions)` the envs that are running."""

    def __init__(self, env_id: str, n: int, env_args: dict[str, Any]) -> None:
        why = supports(env_id, env_args)
        if why is not None:
            raise ValueError(why)
        args = {**env_args, "on_road_exit": "terminate"}
        vec: Any = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", threads=1, **args)
        shard = vec.shards[0]
        if len(vec.shards) != 1 or not isinstance(shard, LocalShard):
            raise ValueError("a slot batch needs the batch in this process (one shard)")
        self.vec = vec
        self.core: Any = shard.core
        if not self.core.p.engine_on or self.core.has_traffic:
            raise ValueError(f"{env_id}: drivers read native slots of tasks without traffic, engine running")
        self.n = n
        self.slots = [BatchSlot(self.core, e) for e in range(n)]
        self.core.reset_rows(np.arange(n), [0] * n)  # every slot in a defined state before its first trial
        self.running = np.zeros(n, dtype=bool)
        self._actions = np.zeros((n, *vec.single_action_space.shape), dtype=vec.single_action_space.dtype)

    def reset(self, e: int, seed: int) -> None:
        """Start env `e`'s episode with `seed` (`OpenDSEnv.reset(seed=seed)`)."""
        self.core.reset_rows(np.array([e]), [seed])
        self.running[e] = True

    def step(self, act: Callable[[int], Any]) -> list[tuple[int, bool, dict[str, Any]]]:
        """One policy step of the running envs, `act(e)` giving env e's action; returns
        (env, left the road, episode_metrics) of each episode that ended."""
        rows = np.flatnonzero(self.running)
        self._snapshot()
        for e in rows.tolist():
            self._actions[e] = act(e)
        self.core.slot_snapshot = None
        _, terminated, truncated, _ = self.core.step_rows(self._actions, self.running.copy())
        ended = np.flatnonzero((terminated | truncated) & self.running).tolist()
        if not ended:
            return []
        self.running[ended] = False
        off = np.abs(self.core.lat) > self.core.off_road_limit  # (the LCT's road test: lct_step's task_end)
        return [(e, bool(terminated[e] and off[e]), m) for e, m in self.core.episodes_metrics(ended)]

    def _snapshot(self) -> None:
        """Every env's `BatchSlot.state()` read from the arrays at once (one `tolist` per
        array, not seven numpy scalar reads per env)."""
        b, s = self.core, self.core.s
        self.core.slot_snapshot = list(
            zip(b.t.tolist(), s.x.tolist(), s.z.tolist(), s.yaw.tolist(), s.u.tolist(), s.r.tolist(), b.revealed.tolist())
        )

    def close(self) -> None:
        self.vec.close()
