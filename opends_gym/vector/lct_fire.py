"""The LCT's trigger actions fired inside the compiled physics pass (`lct_step`).

Why: a car that touched a trigger box stopped the compiled pass (parked) for Python to fire
the trigger (`TriggerBatch.fire`: locks, repeat caps, the actions), and a second kernel call
finished its policy step; under random actions ~4 % of the cars did so every policy step.
The LCT's triggers do little: reveal a sign (`manipulateObject visible`), set up a lane-change
timer (`ReactionCenter.setup`), start the reaction measurement, pause at the end, log. Here
each trigger's actions are a table of codes (`fire_tables`) and `fire_inline` runs them for
one car, with `TriggerBatch.fire`'s and `TimerBatch.setup`'s arithmetic. Only what logs a
result stays Python (the car parks as before): a timer set up while another runs (a missed
trial), a timer that ended earlier in the same call and is not scored yet, or an action
without a code.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..jit import inline
from ..sim.road import LANE_MARGIN_M
from ..sim.triggers.core import LOCK_S
from ..sim.triggers.reactions import EPS
from .kernels import T_DISTANCE_LIMIT, T_TIME_LIMIT, lane_at
from .timers import KINDS, LANE
from .triggers import NO_EFFECT_ACTIONS

SKIP, NOP, PAUSE, START, REVEAL, TIMER, PYTHON = -1, 0, 1, 2, 3, 4, 5  # action codes (`fire_tables`)


def fire_tables(trig: Any, timers: Any, sign_of_model: dict[str, int]) -> tuple[np.ndarray, ...]:
    """(each volume's triggers in firing order, -1 padded; each trigger's pause (s); its
    actions as rows (code, counter, repeat, argument); their number; each timer spec's kind,
    start lane and start speed) for `fire_inline`. Arguments: the sign index of a reveal, the
    spec index of a timer."""
    order = trig._order
    width = max([len(o) for o in order], default=0)
    by_volume = np.array([list(o) + [-1] * (width - len(o)) for o in order], dtype=np.int64).reshape(len(order), width)
    n_acts = np.array([len(tr.actions) for tr in trig.triggers], dtype=np.int64)
    acts = np.zeros((len(trig.triggers), max(1, int(n_acts.max(initial=0))), 4), dtype=np.int64)
    for i, tr in enumerate(trig.triggers):
        for a, act in enumerate(tr.actions):
            code, arg = PYTHON, 0
            if not act.known:
                code = SKIP
            elif act.name in NO_EFFECT_ACTIONS:
                code = NOP
            elif act.name == "pauseSimulation":
                code = PAUSE
            elif act.name == "startReactionMeasurement":
                code = START
            elif act.name == "manipulateObject":  # (`LctBatch._on_action_rows`: anything but a sign shown does nothing)
                k = sign_of_model.get(str(act.args["object_id"]))
                code, arg = (REVEAL, k) if k is not None and act.args.get("visible") else (NOP, 0)
            elif act.name in KINDS:
                code, arg = TIMER, timers._spec_index[act.counter]
            acts[i, a] = code, act.counter, act.repeat, arg
    specs = timers.specs
    return (
        by_volume,
        np.asarray(trig.pause_s, dtype=np.float64).reshape(-1),
        acts,
        n_acts,
        np.array([s.kind for s in specs], dtype=np.int64),
        np.array([s.start_lane for s in specs], dtype=np.int64),
        np.array([s.start_speed_mps for s in specs], dtype=np.float64),
    )


@inline
def fire_inline(e: int, j: int, te: float, xe: float, ze: float, ue: float, fire: tuple, locks: np.ndarray, paused: np.ndarray,
                active: np.ndarray, done: np.ndarray, spec: np.ndarray, timer_f: tuple, braked: np.ndarray, start_lane: np.ndarray,
                timer_table: np.ndarray, bands: np.ndarray) -> bool:  # fmt: skip
    """Fire the triggers of volume j that env e's car (at time te, position xe, ze, speed ue)
    touches, as `TriggerBatch.fire` and the LCT batch's handlers do; False, with nothing
    changed, where Python must (see the module docstring)."""
    order, pause_s, acts, n_acts, spec_kind, spec_lane, spec_speed, counts, started, started_at, revealed, kind, armed_t = fire
    timer_t, timer_x, timer_z, peak, hold_since, tlim, dlim = timer_f
    if done[e] != 0:  # (Python scores it before firing: the order of results, started_at)
        return False
    timers = 0
    for q in range(order.shape[1]):  # (element by element: a kernel run as Python may index a memoryview, `jit.python_buffers`)
        i = order[j, q]
        if i >= 0 and te >= locks[e, i] - 1e-9:
            for a in range(n_acts[i]):
                if acts[i, a, 0] == PYTHON:
                    return False
                if acts[i, a, 0] == TIMER:
                    timers += 1
    if timers > 1 or (timers == 1 and active[e]):
        return False
    for q in range(order.shape[1]):
        i = order[j, q]
        if i < 0 or not te >= locks[e, i] - 1e-9:
            continue
        locks[e, i] = te + LOCK_S + pause_s[i]
        for a in range(n_acts[i]):
            code, counter, repeat, arg = acts[i, a, 0], acts[i, a, 1], acts[i, a, 2], acts[i, a, 3]
            if code == SKIP or (repeat > 0 and counts[e, counter] >= repeat):
                continue
            counts[e, counter] += 1
            if code == PAUSE:
                paused[e] = True
            elif code == START:
                if not started[e]:
                    started[e], started_at[e] = True, te
            elif code == REVEAL:
                if arg > revealed[e]:
                    revealed[e] = arg
            elif code == TIMER and started[e]:  # `TimerBatch.setup` (no trial runs: checked above)
                if kind[e] != spec_kind[arg]:
                    kind[e], hold_since[e], peak[e], braked[e] = spec_kind[arg], np.nan, 0.0, False
                ok = lane_at(xe, bands, LANE_MARGIN_M) == spec_lane[arg] if spec_kind[arg] == LANE else ue >= spec_speed[arg] - EPS
                timer_t[e], timer_x[e], timer_z[e] = te, xe, ze
                tlim[e], dlim[e] = timer_table[arg, T_TIME_LIMIT], timer_table[arg, T_DISTANCE_LIMIT]
                if ok:
                    active[e], spec[e], armed_t[e], peak[e], braked[e] = True, arg, te, 0.0, False
                    start_lane[e] = lane_at(xe, bands, 0.0)
    return True
