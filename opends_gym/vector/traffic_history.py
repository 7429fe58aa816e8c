"""The traffic of an undisturbed world, step by step: what a native DrivingTask batch's worlds share.

Why: in the tasks the batch runs (no random forks, no car that watches the ego's speed, no
trigger action that moves traffic), a world's traffic step depends on its ego car only
through one test in `motion._obstacles`: is the ego car in a traffic car's safety box? Every
reset puts the same cars in the same places, so until its ego car enters a safety box, each
world's traffic is, bit for bit, that of a world whose ego car is far away, at the same
number of physics steps since its reset. This module steps one such world (`ref`, its ego at
infinity, the same kernels and the same leg logic as the batch's worlds) once per step
count and keeps every entry: the full state before step k, and what step k's safety boxes
are (`driving_step.O_*`). A batch world at step k whose ego no box holds takes entry k+1's
positions, headings, speeds and enabled flags (`driving_step.step_shared`) instead of
running 41 cars' kernels; one whose ego is seen takes entry k's full state and steps itself
until its next reset. With random actions most ego cars never come close to the motorway's
traffic, so most worlds cost a box test per car and physics step.

The history grows as the oldest undisturbed world ages, up to `MAX_STEPS` entries (~56 MB
for 41 cars); a world that outlives it steps itself.
"""

from __future__ import annotations

import numpy as np

from ..sim.traffic.motion import CAR, W_FSAFE, W_FX, W_FZ, W_UX, W_UZ
from .driving_step import N_OBS, O_CHECK, O_FSAFE, O_FX, O_FZ, O_LAT, O_UX, O_UZ, O_X, O_Z

MAX_STEPS = 4096  # entries kept at most (68 s at 60 Hz)
GROW = 256  # entries added at a time


class TrafficHistory:
    """Entries 0..`length`-1 of an undisturbed world's traffic (see the module docstring);
    `ref`: that world (a one-world `driving.NetTraffic`), at entry `length`-1."""

    def __init__(self, ref: object, dt: float, max_steps: int = MAX_STEPS) -> None:
        self.ref = ref
        self.dt = dt
        self.max_steps = max_steps
        st = ref.st  # type: ignore[attr-defined]
        self.c = len(st)
        self.hf = np.zeros((0,) + st.f.shape)
        self.hi = np.zeros((0,) + st.i.shape, dtype=st.i.dtype)
        self.hb = np.zeros((0,) + st.b.shape, dtype=bool)
        self.hpos = np.zeros((0,) + st.pos.shape)
        self.hend = np.zeros((0,) + st.end_xz.shape)
        self.hlight = np.zeros((0,) + st.light_xz.shape)
        self.hext = np.zeros((0,) + st.ext_cmd.shape)
        self.hobs = np.zeros((0, N_OBS, self.c))
        self.ht = np.zeros(0)
        self.length = 0
        self._one = np.ones(1, dtype=bool)
        self._far = np.full(1, np.inf)  # the reference world's ego car: no safety box holds it
        self._write(0)

    def arrays(self) -> tuple[np.ndarray, ...]:
        """(hf, hi, hb, hpos, hend, hlight, hext, hobs, ht) for the kernels."""
        return self.hf, self.hi, self.hb, self.hpos, self.hend, self.hlight, self.hext, self.hobs, self.ht

    def _write(self, k: int) -> None:
        """Entry k := the reference world's state now (and the time of its step k)."""
        if k >= len(self.ht):
            cap = min(self.max_steps, len(self.ht) + GROW)
            for name in ("hf", "hi", "hb", "hpos", "hend", "hlight", "hext", "hobs", "ht"):
                old = getattr(self, name)
                new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
                new[: len(old)] = old
                setattr(self, name, new)
        st = self.ref.st  # type: ignore[attr-defined]
        self.hf[k], self.hi[k], self.hb[k] = st.f, st.i, st.b
        self.hpos[k], self.hend[k], self.hlight[k], self.hext[k] = st.pos, st.end_xz, st.light_xz, st.ext_cmd
        self.ht[k] = (np.full(1, k + 1, dtype=np.int64) * self.dt)[0]  # (`BatchCore`'s t: step count x dt)
        self.length = k + 1

    def extend_to(self, k: int) -> None:
        """Entries up to k (at most `max_steps` - 1): step the reference world."""
        k = min(k, self.max_steps - 1)
        ref = self.ref
        while self.length <= k:
            step = self.length - 1
            before = ref.st.pos.copy()  # type: ignore[attr-defined]
            ref.drive_pos = before  # type: ignore[attr-defined]  # (a step that stops for Python records its cars' places at `drive`)
            ref.step(self._one, self.dt, self.ht[step : step + 1], self._far, self._far)  # type: ignore[attr-defined]
            st, work = ref.st, ref.work  # type: ignore[attr-defined]
            o = self.hobs[step]
            o[O_CHECK] = ((ref.flags & CAR) != 0) & ~st.ext  # type: ignore[attr-defined]
            o[O_X], o[O_Z] = before[:, 0], before[:, 2]
            o[O_FX], o[O_FZ], o[O_UX], o[O_UZ], o[O_FSAFE] = work[W_FX], work[W_FZ], work[W_UX], work[W_UZ], work[W_FSAFE]
            o[O_LAT] = st.lat_safe
            self._write(step + 1)
