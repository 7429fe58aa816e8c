"""CPU time of scoring whole LCT episodes in the native batch (a lane-following driver).

The envs of a native LCT batch drive the whole track (18 signs, ~194 s, ~11,600 trace rows)
with a lane-following driver and end together; prints the process's CPU time per ended
episode in the core's scoring call (`episodes_table`, or `episodes_metrics` for a core
without it), on one numba thread unless NUMBA_NUM_THREADS says otherwise. Run it on two
checkouts, alternating, to compare scoring code (`benchmarks/scoring.py` does the same for
short random-action episodes).

    python benchmarks/whole_episode_scoring.py [--envs 64]
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # (the process's CPU time then is the scoring's, whichever thread runs it)

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.jit import wait_compiled


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=64)
    n = ap.parse_args().envs
    vec = gym.make_vec("OpenDS/LaneChangeTest-v0", num_envs=n, vectorization_mode="vector_entry_point")
    core: Any = vec.unwrapped.shards[0].core  # type: ignore[attr-defined]
    spent, ended = [0.0], [0]
    name = "episodes_table" if hasattr(core, "episodes_table") else "episodes_metrics"  # (what `vector.shards` calls)
    score = getattr(core, name)

    def timed(es: list[int]) -> Any:
        t0 = time.process_time()
        out = score(es)
        spent[0] += time.process_time() - t0
        ended[0] += len(es)
        return out

    setattr(core, name, timed)
    obs, _ = vec.reset(seed=0)
    rng = np.random.default_rng(0)
    for i in range(4000):
        a = np.zeros((n, 2), np.float32)
        a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1) + rng.normal(0, 0.02, n)
        obs, *_ = vec.step(a)
        if i == 50:
            wait_compiled()
        if ended[0] >= n:
            break
    if not ended[0]:
        raise SystemExit(f"no episode was scored through {name}: the batch's scoring call has changed")
    print(f"{ended[0]} whole LCT episodes ({i + 1} steps): {1e6 * spent[0] / max(1, ended[0]):,.0f} CPU µs of scoring per episode")
    vec.close()


if __name__ == "__main__":
    main()
