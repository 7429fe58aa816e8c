"""Per-physics-step traces of N episodes in one ring buffer, for the end-of-episode metrics.

Why: SDLP, steering reversal rate and the LCT's MDEV need the whole trace of an episode;
the single env keeps one `envs.trace.Trace` each. Here every physics step writes one
contiguous row (all envs) of each recorded column into a time-major ring; an env's
episode is its reset row (kept aside) plus the ring rows from its first step on, which
stay contiguous because every live env is stepped in every substep. When an episode ends
its rows are copied into a `Trace`, and the single env's own metric code scores it, or (the
batches with compiled scoring) `gather` copies the ended episodes' rows into one array, or
(the LCT's parallel scoring pass) each scoring thread reads its episode in place
(`block_addresses`).
Derived columns (time, lateral position, lane, lane offset) are not stored; `to_trace`
computes them with the guide's formulas.
"""

from __future__ import annotations

import mmap
import os

import numba
import numpy as np
from numba import prange

from ..envs.trace import COL, Trace
from ..jit import kernel, parallel_kernel
from ..sim.guide import RoadGuide
from .block_view import block_at
from .kernels import lane_of

TRACE_GROUP = 8  # rows of one car stored together in a grouped ring (`TraceRing`)
# ... in the brake and platoon batches' ring: an ended episode is read (`gather`) in runs of 32 rows
# (2.3 KB of 9 columns) instead of 8, a cache and TLB miss per run (4,096 platoon envs with
# metrics, one thread: `gather`'s compiled copy 0.58 -> 0.09 s per 200 steps, cProfile)
PLATOON_TRACE_GROUP = 32


class TraceRing:
    """`columns` recorded per physics step for `n` envs; episodes up to `max_steps` long.
    Columns that are not `Trace` columns (task measures) are read with `column`.

    Rows live in blocks of BLOCK rows: one (BLOCK, n, columns) array per block (a car's values
    of one step share a cache line; for the step loops that write one row of every car at a
    time), or with `grouped` one (BLOCK / GROUP, n, GROUP, columns) array: a car's GROUP
    rows of a group are contiguous (256 bytes), for a step loop that runs each car's physics
    steps in turn (the LCT's: its rows of a policy step mostly in one group, the cars one
    after another in memory) and for reading an ended episode, which in the time-major
    layout costs a cache and TLB miss per row (~50 µs for a ~300-row episode, in the serial
    part of a step). A block is
    allocated when first written and recycled once no running episode reaches back into it,
    so memory grows with the longest running episode (not with `max_steps` up front), short
    episodes stay in cache, and nothing is ever copied to make room.
    """

    BLOCK = 256
    GROUP = TRACE_GROUP

    def __init__(self, n: int, columns: tuple[str, ...], max_steps: int, grouped: bool = False, group: int = TRACE_GROUP) -> None:
        """`group`: rows of a car stored together when `grouped` (a divisor of BLOCK; the
        compiled writers take it as a constant: TRACE_GROUP or PLATOON_TRACE_GROUP)."""
        if TraceRing.BLOCK % group:
            raise ValueError(f"group must divide {TraceRing.BLOCK}, got {group}")
        self.columns = columns
        self.grouped = grouped
        self.GROUP = group
        self.n = n
        self.size = int(max_steps) + 2  # the most rows an episode can have
        need = self.size * n * len(columns) * 8
        if need > 0.6 * _physical_memory():
            raise MemoryError(
                f"the episode traces of {n} envs need {need / 2**30:.1f} GiB (for episode_metrics); "
                "use fewer envs, a shorter max_episode_s, or record_metrics=False"
            )
        self.index = {c: i for i, c in enumerate(columns)}
        self.blocks: dict[int, np.ndarray] = {}  # block number (g // BLOCK) -> (BLOCK rows, n, column) or (n, BLOCK rows, column)
        self._listed: tuple[np.ndarray, int] | None = None  # `block_addresses`'
        self._spare: list[np.ndarray] = []
        self.first = {c: np.zeros(n) for c in columns}  # the reset row of each env's episode
        self.g = 0  # rows written so far
        self.start = np.zeros(n, dtype=np.int64)  # g of each env's first step row
        self.steps = np.zeros(n, dtype=np.int64)  # step rows of each env's episode so far

    def reset_rows(self, idx: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Episodes of `idx` start: their reset rows; their step rows begin at the next write."""
        for c in self.columns:
            self.first[c][idx] = values[c]
        self.start[idx] = self.g
        self.steps[idx] = 0

    def write(self, values: dict[str, np.ndarray], live: np.ndarray | None) -> None:
        """One physics step: a row for every env (rows of envs not `live` are never read)."""
        block, row = self.reserve(1)[0], self.g % self.BLOCK
        for c, i in self.index.items():
            if self.grouped:
                block[row // self.GROUP, :, row % self.GROUP, i] = values[c]
            else:
                block[row, :, i] = values[c]
        self.g += 1
        if live is None:
            self.steps += 1
        else:
            self.steps[live] += 1

    def reserve(self, rows: int) -> tuple[np.ndarray, np.ndarray]:
        """The blocks holding the next `rows` (<= BLOCK) rows, from row g on: (block of row g,
        block after it: the same one when they all fit). For writers that fill rows themselves
        (a compiled step loop) and then advance `g` and `steps`."""
        b = self.g // self.BLOCK
        first = self.blocks.get(b)
        if first is None:
            first = self._new_block(b)
        if (self.g + rows - 1) // self.BLOCK == b:
            return first, first
        second = self.blocks.get(b + 1)
        return first, second if second is not None else self._new_block(b + 1)

    def set_last(self, c: str, values: np.ndarray) -> None:
        """Overwrite column c of the row written last (a measure known only after the row)."""
        b, row = divmod(self.g - 1, self.BLOCK)
        if self.grouped:
            self.blocks[b][row // self.GROUP, :, row % self.GROUP, self.index[c]] = values
        else:
            self.blocks[b][row, :, self.index[c]] = values

    def _new_block(self, b: int) -> np.ndarray:
        oldest = int(self.start.min()) // self.BLOCK  # blocks before it hold no running episode's rows
        for old in [k for k in self.blocks if k < oldest]:
            self._spare.append(self.blocks.pop(old))
        c = len(self.columns)
        shape = (self.BLOCK // self.GROUP, self.n, self.GROUP, c) if self.grouped else (self.BLOCK, self.n, c)
        block = self._spare.pop() if self._spare else _fresh_block(shape)
        self.blocks[b] = block
        self._listed = None
        return block

    def block_addresses(self) -> tuple[np.ndarray, int]:
        """(the address of every block held, in order (0: none), as int64; the number of the
        first), for compiled code that reads episodes straight from the ring
        (`lct_score_pass.read_episode`; the blocks stay held in `blocks` while it runs). Built
        again only after a block was added (every BLOCK rows), not per call."""
        if self._listed is None:
            lo, hi = (min(self.blocks), max(self.blocks)) if self.blocks else (0, 0)
            held = [self.blocks.get(b) for b in range(lo, hi + 1)]
            self._listed = (np.array([0 if a is None else a.ctypes.data for a in held], dtype=np.int64), lo)
        return self._listed

    def column(self, e: int, c: str) -> np.ndarray:
        """Env e's episode so far for one column (reset row first)."""
        k = int(self.steps[e])
        out = np.empty(k + 1)
        out[0] = self.first[c][e]
        ci = self.index[c]
        g, end, i = int(self.start[e]), int(self.start[e]) + k, 1
        while g < end:
            b, row = divmod(g, self.BLOCK)
            take = min(self.BLOCK - row, end - g)
            block = self.blocks[b]
            if self.grouped:
                rr = np.arange(row, row + take)
                out[i : i + take] = block[rr // self.GROUP, e, rr % self.GROUP, ci]
            else:
                out[i : i + take] = block[row : row + take, e, ci]
            g, i = g + take, i + take
        return out

    def gather(self, es: list[int], parallel: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The episodes so far of the envs `es` one after another: (starts, data), data's
        (column, row) rows starts[j]..starts[j+1]-1 env es[j]'s episode (reset row first), for
        scoring them in one compiled pass. Copied in compiled code: a grouped ring's episodes
        each read in place (`read_rows`; chunks of them on numba's threads where `parallel`),
        the other layout a block at a time."""
        idx = np.asarray(es, dtype=np.int64)
        counts = self.steps[idx] + 1
        starts = np.zeros(len(es) + 1, dtype=np.int64)
        np.cumsum(counts, out=starts[1:])
        data = np.empty((len(self.columns), int(starts[-1])))
        if not len(es):
            return starts, data
        if self.grouped:  # (each episode read in place, `read_rows`)
            blocks, b0 = self.block_addresses()
            shape = (self.BLOCK // self.GROUP, self.n, self.GROUP, len(self.columns))
            args = (idx, blocks, b0, shape, tuple(self.first[c] for c in self.columns), self.start, self.steps, starts, data)
            if parallel:
                with numba.parallel_chunksize(1):  # (episodes differ in length: threads take a chunk at a time)
                    _gather_episodes(episode_chunks(len(es)), *args)
            else:
                _gather_range(0, len(es), *args)
            return starts, data
        for ci, c in enumerate(self.columns):
            data[ci, starts[:-1]] = self.first[c][idx]
        lo, hi = int(self.start[idx].min()), int((self.start[idx] + self.steps[idx]).max())
        for b in range(lo // self.BLOCK, (hi - 1) // self.BLOCK + 1) if hi > lo else ():
            _gather_block(self.blocks[b], b * self.BLOCK, idx, self.start, self.steps, starts, data)
        return starts, data

    def columns_of(self, es: list[int]) -> dict[int, np.ndarray]:
        """The episodes so far of the envs `es` (reset row first), as one (column, row) array
        each. Envs whose episodes started together are read together, a block's rows at a
        time (reading one env's column alone touches a cache line per row)."""
        groups: dict[tuple[int, int], list[int]] = {}
        for e in es:
            groups.setdefault((int(self.start[e]), int(self.steps[e])), []).append(e)
        out: dict[int, np.ndarray] = {}
        for (g, k), members in groups.items():
            idx = np.asarray(members)
            data = np.empty((len(self.columns), len(members), k + 1))
            for ci, c in enumerate(self.columns):
                data[ci, :, 0] = self.first[c][idx]
            end, i = g + k, 1
            while g < end:
                b, row = divmod(g, self.BLOCK)
                take = min(self.BLOCK - row, end - g)
                block = self.blocks[b]
                if self.grouped:
                    rr = np.arange(row, row + take)[:, None]
                    data[:, :, i : i + take] = block[rr // self.GROUP, idx[None, :], rr % self.GROUP, :].transpose(2, 1, 0)
                else:
                    data[:, :, i : i + take] = block[row : row + take, idx, :].transpose(2, 1, 0)
                g, i = g + take, i + take
            for j, e in enumerate(members):
                out[e] = data[:, j, :]
        return out

    def to_trace(self, e: int, guide: RoadGuide, dt_s: float, constant: dict[str, float], columns: np.ndarray | None = None) -> Trace:
        """Env e's episode as the single env's `Trace` (missing columns from `constant`;
        `columns`: its `columns_of` array, when read already)."""
        k = int(self.steps[e]) + 1
        tr = Trace(capacity=max(k, 1))
        data = tr._data
        data[:, COL["t_s"]] = np.arange(k) * dt_s
        for ci, c in enumerate(self.columns):
            if c in COL:
                data[:, COL[c]] = self.column(e, c) if columns is None else columns[ci]
        for c, v in constant.items():
            data[:, COL[c]] = v
        if not {"lateral_m", "lane_index", "lane_offset_m"} <= set(self.columns):  # (a batch on a route records them)
            lat, lane, offset = lane_columns(guide, data[:, COL["x_m"]], data[:, COL["z_m"]])
            data[:, COL["lateral_m"]] = lat
            data[:, COL["lane_index"]] = lane
            data[:, COL["lane_offset_m"]] = offset
        tr.n = k
        if hasattr(tr, "_stored"):  # the single env's Trace buffers appended rows
            tr._stored = k
            tr._last = tuple(float(v) for v in data[k - 1])
        return tr


def _fresh_block(shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised float array in anonymous memory of ordinary pages. (numpy's own
    allocations of 4 MB and more ask the kernel for huge pages; where the kernel then
    compacts memory to find one at the first write, the compiled step stalled for
    milliseconds every 2 MB of trace: -25 % env-steps/s for a 4,096-env LCT batch here.)"""
    nbytes = max(8, int(np.prod(shape)) * 8)
    return np.frombuffer(mmap.mmap(-1, nbytes), dtype=np.float64).reshape(shape)


def _physical_memory() -> float:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # not POSIX: no check
        return float("inf")


@kernel
def _gather_block(block: np.ndarray, g0: int, es: np.ndarray, start: np.ndarray, steps: np.ndarray, starts: np.ndarray,
                  data: np.ndarray) -> None:  # fmt: skip
    """`TraceRing.gather`'s rows g0..g0+BLOCK-1 (one block) of the episodes es."""
    for j in range(len(es)):
        e = es[j]
        lo, hi = max(start[e], g0), min(start[e] + steps[e], g0 + len(block))
        out = starts[j] + 1 - start[e]
        for g in range(lo, hi):
            for c in range(block.shape[2]):
                data[c, out + g] = block[g - g0, e, c]


RING_BLOCK = TraceRing.BLOCK  # (a module constant: compiled code cannot read class attributes)


def episode_chunks(m: int) -> int:
    """How many chunks a parallel pass over m ended episodes splits them into: a few per
    thread, since episode lengths differ (what an episode gets does not depend on it). Taken
    in Python: numba's `get_num_threads` in a kernel keeps it out of the cache."""
    return max(1, min(m, 4 * numba.get_num_threads()))


@parallel_kernel
def _gather_episodes(chunks: int, es: np.ndarray, blocks: np.ndarray, b0: int, shape: tuple[int, int, int, int], first: tuple,
                     start: np.ndarray, steps: np.ndarray, starts: np.ndarray, data: np.ndarray) -> None:  # fmt: skip
    """`_gather_range` of every episode, `chunks` chunks of them on numba's threads."""
    m = len(es)
    for k in prange(chunks):
        _gather_range(k * m // chunks, (k + 1) * m // chunks, es, blocks, b0, shape, first, start, steps, starts, data)


@kernel
def _gather_range(j0: int, j1: int, es: np.ndarray, blocks: np.ndarray, b0: int, shape: tuple[int, int, int, int], first: tuple,
                  start: np.ndarray, steps: np.ndarray, starts: np.ndarray, data: np.ndarray) -> None:  # fmt: skip
    """`TraceRing.gather` of a grouped ring for episodes j0..j1-1: episode j (env es[j]) into
    data[:, starts[j]:starts[j+1]]."""
    for j in range(j0, j1):
        read_rows(es[j], blocks, b0, shape, first, start, steps, data, starts[j])


@kernel
def read_rows(e: int, blocks: np.ndarray, b0: int, shape: tuple[int, int, int, int], first: tuple, start: np.ndarray, steps: np.ndarray,
              data: np.ndarray, at: int) -> None:  # fmt: skip
    """Env e's episode so far from a grouped ring (reset row first) into data[:, at:at + steps[e] + 1]
    (column, row): `TraceRing.block_addresses`' blocks and first block number, the blocks'
    shape (BLOCK / group, n, group, columns), its reset rows (`first`: one array per column),
    start and steps. A car's rows of a block lie in runs of `group` rows, walked group by
    group (no division per row)."""
    group, c_n = shape[2], len(first)
    for c in range(c_n):
        data[c, at] = first[c][e]
    g, end, i = start[e], start[e] + steps[e], at + 1
    while g < end:  # a block at a time
        block = block_at(blocks[g // RING_BLOCK - b0], shape)
        r0 = g % RING_BLOCK
        take = min(RING_BLOCK - r0, end - g)
        grp, slot = r0 // group, r0 % group
        for k in range(take):
            for c in range(c_n):
                data[c, i + k] = block[grp, e, slot, c]
            slot += 1
            if slot == group:
                grp, slot = grp + 1, 0
        g, i = g + take, i + take


def lane_columns(guide: RoadGuide, x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lateral position, lane index, offset from the lane centre) as `RoadGuide.locate` and
    `OpenDSEnv._record_row` compute them, for X-band lane roads."""
    if guide.kind != "lanes":
        raise ValueError("the native batch needs a task with lane bands")
    x = np.ascontiguousarray(x, dtype=np.float64)
    lat, lane, offset = np.empty(len(x)), np.empty(len(x), dtype=np.int64), np.empty(len(x))
    _lane_columns(x, guide.sign, np.asarray(guide.lane_laterals_m, dtype=np.float64), guide.lane_width_m / 2.0, lat, lane, offset)
    return lat, lane, offset


@kernel
def _lane_columns(x: np.ndarray, sign: float, centres: np.ndarray, half: float, lat: np.ndarray, lane: np.ndarray,
                  offset: np.ndarray) -> None:  # fmt: skip
    for e in range(len(x)):
        la = -sign * x[e]
        ln, ref = lane_of(la, centres, half)
        lat[e], lane[e], offset[e] = la, ln, la - centres[ref]


@kernel
def score_columns(starts: np.ndarray, x: np.ndarray, z: np.ndarray, steer: np.ndarray, dt: float, sign: float, centres: np.ndarray,
                  half: float, steer_deg: float, out: np.ndarray) -> None:  # fmt: skip
    """The derived columns of `TraceRing.gather`'s episodes (rows starts[j]..starts[j+1]-1
    episode j's) for their scoring, in one pass: out rows time (`to_trace`'s clock),
    `lane_columns`' lateral position, lane (as a float) and lane offset, the steering wheel
    angle (steer x steer_deg) and the `np.hypot` step to the next row (np.diff's, across
    episodes too; the last row's 0)."""
    total = len(x)
    for j in range(len(starts) - 1):
        for i in range(starts[j], starts[j + 1]):
            out[0, i] = float(i - starts[j]) * dt
    for i in range(total):
        la = -sign * x[i]
        ln, ref = lane_of(la, centres, half)
        out[1, i], out[2, i], out[3, i] = la, float(ln), la - centres[ref]
        out[4, i] = steer[i] * steer_deg
        out[5, i] = np.hypot(x[i + 1] - x[i], z[i + 1] - z[i]) if i + 1 < total else 0.0
