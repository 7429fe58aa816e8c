"""A trace ring of bounded size: the oldest block's rows of the episodes still running move out before it is reused.

Why: `TraceRing` keeps every block back to the oldest running episode's first row. Under random actions a few of a brake or
platoon batch's envs drive for minutes while the others end within seconds, so the ring grew by a fresh block (92 MB for
4,096 brake envs) every 43 policy steps, up to `max_episode_s` of rows for every env (GBs), and the compiled step took a
page fault per 4 KB of it (serialised between threads by the kernel). Here the ring holds at most `max_blocks` blocks: when
it needs another, the rows the oldest block holds of episodes still running are copied out (`spill`, a short list of arrays
per env; a few hundred envs of 4,096) and the block is reused. Readers see the same rows in the same order."""

from __future__ import annotations

import numpy as np

from .trace import TraceRing, _gather_block, _gather_block_grouped


class SpillRing(TraceRing):
    """`TraceRing` of at most `max_blocks` (>= 3) blocks; the rows of env e's episode before
    row `start[e] + spilled[e]` lie in `spill[e]` (arrays of (rows, columns), oldest first)."""

    def __init__(self, n: int, columns: tuple[str, ...], max_steps: int, grouped: bool = False, max_blocks: int = 4) -> None:
        super().__init__(n, columns, max_steps, grouped)
        self.max_blocks = max(3, int(max_blocks))  # (a reserve takes the newest two; the oldest is older than both)
        self.spilled = np.zeros(n, dtype=np.int64)
        self.spill: dict[int, list[np.ndarray]] = {}

    def reset_rows(self, idx: np.ndarray, values: dict[str, np.ndarray]) -> None:
        idx = np.asarray(idx, dtype=np.int64)
        if self.spill:
            for e in idx[self.spilled[idx] > 0].tolist():
                self.spill.pop(e, None)
        self.spilled[idx] = 0
        super().reset_rows(idx, values)

    def _new_block(self, b: int) -> np.ndarray:
        oldest = int((self.start + self.spilled).min()) // self.BLOCK  # blocks before it hold no running episode's rows
        for old in [k for k in self.blocks if k < oldest]:
            self._spare.append(self.blocks.pop(old))
        if not self._spare and len(self.blocks) >= self.max_blocks:
            o = min(self.blocks)
            self._spill_block(o)
            self._spare.append(self.blocks.pop(o))
        return super()._new_block(b)

    def _spill_block(self, o: int) -> None:
        """Copy the rows block o holds of every episode into its env's `spill`."""
        lo_g, hi_g = o * self.BLOCK, (o + 1) * self.BLOCK
        first = self.start + self.spilled  # each env's first row still in the ring
        end = np.minimum(self.start + self.steps, hi_g)
        block = self.blocks[o]
        for e in np.flatnonzero(end > first).tolist():
            a, z = max(int(first[e]), lo_g) - lo_g, int(end[e]) - lo_g
            if self.grouped:
                rr = np.arange(a, z)
                rows = block[rr // self.GROUP, e, rr % self.GROUP, :]
            else:
                rows = block[a:z, e, :].copy()
            self.spill.setdefault(e, []).append(rows)
            self.spilled[e] += z - a

    def gather(self, es: list[int]) -> tuple[np.ndarray, np.ndarray]:
        idx = np.asarray(es, dtype=np.int64)
        counts = self.steps[idx] + 1
        starts = np.zeros(len(es) + 1, dtype=np.int64)
        np.cumsum(counts, out=starts[1:])
        data = np.empty((len(self.columns), int(starts[-1])))
        for ci, c in enumerate(self.columns):
            data[ci, starts[:-1]] = self.first[c][idx]
        if not len(es):
            return starts, data
        sp = self.spilled[idx]
        for j in np.flatnonzero(sp > 0).tolist():
            at = int(starts[j]) + 1
            for rows in self.spill[es[j]]:
                data[:, at : at + len(rows)] = rows.T
                at += len(rows)
        start, steps, out_at = self.start + self.spilled, self.steps - self.spilled, starts + np.append(sp, 0)
        lo, hi = int(start[idx].min()), int((start[idx] + steps[idx]).max())
        gather_block = _gather_block_grouped if self.grouped else _gather_block
        for b in range(lo // self.BLOCK, (hi - 1) // self.BLOCK + 1) if hi > lo else ():
            block = self.blocks.get(b)  # (a block spilled and reused holds no row of these episodes: an env not stepped since its reset)
            if block is not None:
                gather_block(block, b * self.BLOCK, idx, start, steps, out_at, data)
        return starts, data

    def column(self, e: int, c: str) -> np.ndarray:
        out: np.ndarray = self.gather([e])[1][self.index[c]]
        return out

    def columns_of(self, es: list[int]) -> dict[int, np.ndarray]:
        starts, data = self.gather(es)
        return {e: data[:, starts[j] : starts[j + 1]] for j, e in enumerate(es)}
