"""The native brake and platoon batches give the same trajectories whatever numba's thread count.

Their policy step is one compiled pass whose chunks of envs run on numba's threads
(`vector.platoon_pass`, `vector.platoon_finish`); each chunk must compute what it computes
alone, so 1, 2 and 7 threads (more threads than this host may have cores) must agree bit for
bit: observations, rewards, flags, info and episode metrics, through autoresets.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = """
import hashlib, sys
import gymnasium as gym
import numpy as np
import opends_gym  # noqa: F401 (registers the ids)
from opends_gym.vector.kernels import CHUNK_ENVS

digest = hashlib.sha256()
n = 2 * CHUNK_ENVS + 3
for env_id, kw in (("OpenDS/BrakeReaction-v0", {"stimuli": 3, "track_seed": 3, "max_episode_s": 10.0}),
                   ("OpenDS/ThreeVehiclePlatoon-v0", {"stimuli": 5, "lead_in_m": 100.0, "spacing_min_m": 200.0,
                                                      "spacing_max_m": 220.0, "max_episode_s": 10.0})):
    vec = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", policy_hz=5, **kw)
    obs, _ = vec.reset(seed=11)
    rng = np.random.default_rng(3)
    ends = 0
    for t in range(30):
        a = rng.uniform(-1.0, 1.0, vec.action_space.shape).astype(np.float32)
        a[:, 1] = np.where(obs[:, 0] > 15.0, -0.5, 0.6)  # (around 54 km/h, so the stimuli come)
        obs, r, term, trunc, info = vec.step(a)
        ends += int(np.sum(term | trunc))
        for x in (obs, r, term, trunc):
            digest.update(np.ascontiguousarray(x).tobytes())
        for key in sorted(info):
            if key == "episode_metrics":
                for mk in sorted(info[key]):
                    digest.update(np.ascontiguousarray(info[key][mk]).tobytes())
            elif isinstance(info[key], np.ndarray) and info[key].dtype != object:
                digest.update(np.ascontiguousarray(info[key]).tobytes())
    vec.close()
    print(env_id, "ended", ends, file=sys.stderr)
print(digest.hexdigest())
"""


def _trajectory_hash(threads: int) -> tuple[str, str]:
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=env, cwd=ROOT, capture_output=True, text=True, timeout=600, check=True)
    return done.stdout.strip().splitlines()[-1], done.stderr


def test_brake_and_platoon_trajectories_identical_at_1_2_and_7_threads() -> None:
    one, log = _trajectory_hash(1)
    ends = [int(line.split()[-1]) for line in log.splitlines() if " ended " in line]
    assert len(ends) == 2 and min(ends) >= 20, log  # both tasks ran through autoresets
    assert _trajectory_hash(2)[0] == one
    assert _trajectory_hash(7)[0] == one
