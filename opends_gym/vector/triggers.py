"""The trigger core of a native batch: trigger boxes touched, 2 s locks, repeat caps, actions.

Why: `sim.triggers.TriggerCore` for N worlds of one task. The contact test (is the car's
box over a trigger box?) runs as array maths every physics step: each env has at most one
trigger volume within reach at a time (checked when the table is built), found by a
sorted search along the road, and only envs near one get the exact separating-axis test of
`sim.geometry2d.obb_overlap`, with the same arithmetic. Firing is rare: the few (env,
trigger) pairs that fire and are not locked run their actions for all such envs at once,
through the handler the task batch gives (`run(envs, action, trigger)`).

Supported, because the three batched tasks use nothing else: `collideWith` conditions,
actions without delay, `pauseSimulation` until resumed (it ends the episode) and the
actions the task handler knows. Anything else is refused when the table is built, with the
trigger named, so a task the batch cannot run exactly is never run inexactly.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..sim.triggers.core import LOCK_S, CompiledAction, TriggerCore, canonical_key
from .kernels import N_VOL, touch_triggers

_NONE = np.zeros(0, dtype=np.int64)
NO_EFFECT_ACTIONS = frozenset({"startRecording", "stopRecording"})  # logged by OpenDS, no effect on the drive


@dataclass(frozen=True)
class Volume:
    """A trigger box (the model named by a collideWith condition) and the triggers it fires."""

    cx: float
    cz: float
    yaw: float
    hx: float
    hz: float
    triggers: tuple[int, ...]


class TriggerBatch:
    """Trigger state of N envs of one task (see the module docstring)."""

    spaced = True  # volumes must lie apart along z (`touching`'s search; a subclass that tests every volume sets False)

    def __init__(self, n: int, world: Any, handled: frozenset[str], car_half: tuple[float, float], car_height_m: float,
                 pressable: frozenset[str] | None = None) -> None:  # fmt: skip
        core: TriggerCore = world.triggers
        self.triggers = core.triggers
        for trig, source in zip(core.triggers, core._source_triggers):
            kinds = {type(c).__name__ for c in source.condition.items}
            if pressable is not None and kinds == {"PressKey"}:
                keys = {canonical_key(c.key) for c in source.condition.items} & {canonical_key(k) for k in pressable}
                if keys:
                    raise ValueError(f"trigger '{trig.id}' (line {trig.line}): the native batch does not press key {sorted(keys)[0]!r}")
                continue  # no action of the batch presses its key: it never fires
            if kinds - {"CollideWith"}:
                raise ValueError(f"trigger '{trig.id}' (line {trig.line}): the native batch supports collideWith conditions only")
            for act in trig.actions:
                self._check_action(trig.id, act, handled)
        ego_y = world.ego.state.y
        vols = []
        for model_id, tis in core._by_model.items():
            for o in world.objects.by_id.get(model_id, ()):
                lo, hi = o.y_range()
                if hi < ego_y - 0.5 or lo > ego_y + car_height_m:
                    continue  # never reachable on flat ground
                hx, _, hz = o.half
                vols.append(Volume(o.position[0], o.position[2], o.yaw, hx, hz, tuple(tis)))
        vols.sort(key=lambda v: v.cz)
        self.volumes = vols
        car_r = math.hypot(*car_half)
        for a, b in itertools.pairwise(vols if self.spaced else []):
            if b.cz - a.cz <= 2.0 * max(math.hypot(a.hx, a.hz), math.hypot(b.hx, b.hz)) + 2.0 * car_r + 2.0:
                raise ValueError("trigger volumes lie too close together for the native batch's contact search")
        self.car_half = car_half
        # one row per volume (columns `kernels.V_*`): one array, as each array an inlined kernel takes costs a reference count
        self.vols = np.array(
            [(v.cz, v.cx, math.hypot(v.hx, v.hz) + car_r + 1.0, v.yaw, v.hx, v.hz, math.sin(v.yaw), math.cos(v.yaw), car_r) for v in vols]
        ).reshape(-1, N_VOL)
        self.pause_s = np.array([t.pause_s for t in self.triggers])
        width = max([len(v.triggers) for v in vols], default=0)
        padded = [list(v.triggers) + [-1] * (width - len(v.triggers)) for v in vols]
        self.vol_triggers = np.array(padded, dtype=np.int64).reshape(len(vols), width)  # each volume's triggers, -1 padded
        self.contact = np.full(n, -1, dtype=np.int64)
        self.near = np.zeros(n, dtype=np.int64)  # where each env's car was in the volume table (a search hint)
        # each volume's triggers in firing order (priority, then position)
        self._order = [sorted(v.triggers, key=lambda i: (-self.triggers[i].priority, i)) for v in vols]
        self.n_counters = core._n_counters
        self.locks = np.full((n, len(self.triggers)), -np.inf)
        self.counts = np.zeros((n, max(1, self.n_counters)), dtype=np.int64)
        self.paused = np.zeros(n, dtype=bool)
        self.started = np.zeros(n, dtype=bool)
        self.started_at = np.zeros(n)

    @staticmethod
    def _check_action(trigger_id: str, act: CompiledAction, handled: frozenset[str]) -> None:
        where = f"trigger '{trigger_id}', action '{act.name}' (line {act.line})"
        if not act.known:
            return  # skipped with a warning, as in the single env
        if act.delay_s > 0.0:
            raise ValueError(f"{where}: delayed actions are not supported by the native batch")
        if act.name == "pauseSimulation" and float(act.args.get("duration_s", 1.0)) > 0:
            raise ValueError(f"{where}: timed pauses are not supported by the native batch")
        if act.name == "manipulateObject":
            extra = {k for k, v in act.args.items() if v is not None} - {"object_id", "visible"}
            if extra:
                raise ValueError(f"{where}: only 'visible' is supported by the native batch (not {sorted(extra)})")
        if act.name not in handled | NO_EFFECT_ACTIONS | {"pauseSimulation", "startReactionMeasurement"}:
            raise ValueError(f"{where}: not supported by the native batch")

    def reset_rows(self, idx: np.ndarray) -> None:
        self.locks[idx] = -np.inf
        self.counts[idx] = 0
        self.paused[idx] = False
        self.started[idx] = False
        self.started_at[idx] = 0.0

    # ------------------------------------------------------------------ contacts
    def touching(self, x: np.ndarray, z: np.ndarray, yaw: np.ndarray, shift: float, rows: np.ndarray,
                 t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """(env rows, volume index) of every car box (reference point x, z, heading yaw, the box
        centred `shift` ahead) of the envs `rows` over a trigger box with a trigger not locked
        at time t."""
        n = touch_triggers(x, z, yaw, shift, rows, self.car_half[0], self.car_half[1], self.vols,
                           self.vol_triggers, t, self.locks, self.near, self.contact)  # fmt: skip
        if n == 0:
            return _NONE, _NONE
        env = np.flatnonzero(self.contact >= 0)
        return env, self.contact[env]

    def fire(self, t: np.ndarray, env: np.ndarray, vol: np.ndarray, run: Callable[[np.ndarray, CompiledAction, int], None]) -> None:
        """Fire the triggers of the touched volumes: skip locked ones, lock, run their actions.

        Envs are independent, so each trigger's actions run for all envs touching its volume
        at once (`run(envs, action, trigger)` for the task's actions); per env, the order of
        triggers (by priority) and of actions is the single env's.
        """
        for j in np.unique(vol).tolist():
            es = env[vol == j]
            for i in self._order[j]:
                now = t[es]
                ok = now >= self.locks[es, i] - 1e-9
                fire, now = es[ok], now[ok]
                if fire.size == 0:
                    continue
                self.locks[fire, i] = now + LOCK_S + self.triggers[i].pause_s
                for act in self.triggers[i].actions:
                    if not act.known:
                        continue
                    rows = fire
                    if act.repeat > 0:
                        rows = fire[self.counts[fire, act.counter] < act.repeat]
                    if rows.size == 0:
                        continue
                    self.counts[rows, act.counter] += 1
                    if not self._builtin(rows, act, t):
                        run(rows, act, i)

    def _builtin(self, rows: np.ndarray, act: CompiledAction, t: np.ndarray) -> bool:
        if act.name in NO_EFFECT_ACTIONS:
            return True
        if act.name == "pauseSimulation":
            self.paused[rows] = True  # until resumed: the episode is over
            return True
        if act.name == "startReactionMeasurement":
            new = rows[~self.started[rows]]
            self.started[new] = True
            self.started_at[new] = t[new]
            return True
        return False


def obb_overlap(
    ax: np.ndarray,
    az: np.ndarray,
    ayaw: np.ndarray,
    ahx: Any,
    ahz: Any,
    bx: np.ndarray,
    bz: np.ndarray,
    byaw: np.ndarray,
    bhx: Any,
    bhz: Any,
) -> np.ndarray:
    """`sim.geometry2d.obb_overlap(a, b)` per row, with the same arithmetic."""
    dx, dz = bx - ax, bz - az
    ra = ahx * ahx + ahz * ahz
    rb = bhx * bhx + bhz * bhz
    d2 = dx * dx + dz * dz
    ok = ~(d2 > ra + rb + 2.0 * np.sqrt(ra * rb))
    ca, sa = np.cos(ayaw), np.sin(ayaw)
    cb, sb = np.cos(byaw), np.sin(byaw)
    a_axes = ((ca, -sa), (sa, ca))
    b_axes = ((cb, -sb), (sb, cb))
    for ux, uz in (*a_axes, *b_axes):
        proj_a = ahx * np.abs(a_axes[0][0] * ux + a_axes[0][1] * uz) + ahz * np.abs(a_axes[1][0] * ux + a_axes[1][1] * uz)
        proj_b = bhx * np.abs(b_axes[0][0] * ux + b_axes[0][1] * uz) + bhz * np.abs(b_axes[1][0] * ux + b_axes[1][1] * uz)
        ok &= ~(np.abs(dx * ux + dz * uz) > proj_a + proj_b)
    return ok
