"""The compiled episode scoring (platoon/brake band and stimulus metrics) gives numpy's floats exactly."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.envs.platoon_core import PlatoonState, Stimulus
from opends_gym.jit import wait_compiled
from opends_gym.metrics import platoon_scores as scores
from opends_gym.metrics import sums


def _wide(rng: np.random.Generator, n: int) -> np.ndarray:
    """Values over 16 orders of magnitude: any other summation order changes the last bits."""
    return rng.standard_normal(n) * 10.0 ** rng.integers(-8, 9, n)


def test_np_sum_adds_in_numpys_order() -> None:
    rng = np.random.default_rng(3)
    arrays = [_wide(rng, n) for n in (*range(0, 40), 127, 128, 129, 255, 256, 300, 1000, 4099)]
    for run in (sums.np_sum.py_func, None):  # as Python, then compiled
        if run is None:
            sums.np_sum(arrays[0], 0, 0)
            wait_compiled()
            run = sums.np_sum
        for a in arrays:
            lo = 3 if len(a) > 3 else 0
            assert run(a, lo, len(a) - lo) == np.sum(a[lo:]), len(a)


def _episode(rng: np.random.Generator, n: int, n_stimuli: int) -> tuple[np.ndarray, np.ndarray, list[Stimulus]]:
    lon = np.where(rng.random(n) < 0.4, 0.0, np.abs(_wide(rng, n)))
    off = rng.uniform(-2.5, 2.5, n)
    stimuli = []
    for _ in range(n_stimuli):
        onset = float(rng.uniform(0, 60))
        result = int(rng.choice([1, -2, 0]))
        reaction = onset + float(rng.uniform(0.2, 2.0)) if result == 1 else float("nan")
        stimuli.append(Stimulus(str(rng.choice(scores.KINDS)), onset, onset + 2.5, reaction_s=reaction, result=result))
    return lon, off, stimuli


def test_platoon_scores_equal_the_single_envs_metrics() -> None:
    """Episodes of 0 to 300 steps (numpy's pairwise blocks and their remainders), with and
    without stimuli of every kind and result, scored together, equal `PlatoonCore.metrics`
    of each (the lateral deviations taken from the lane offsets as the native batch does;
    unscored stimuli whose reaction window is over at the episode's end count as misses)."""
    env = gym.make("OpenDS/ThreeVehiclePlatoon-v0")
    core = env.unwrapped.platoon  # type: ignore[attr-defined]
    band = core.spec.lateral_tolerance
    rng = np.random.default_rng(11)
    episodes = [_episode(rng, n, k) for n, k in ((0, 0), (1, 0), (7, 1), (8, 12), (9, 3), (130, 20), (300, 7), (17, 40))]
    starts = np.cumsum([0] + [len(ep[0]) for ep in episodes])
    stim_starts = np.cumsum([0] + [len(ep[2]) for ep in episodes])
    stims = [s for ep in episodes for s in ep[2]]
    t_end = rng.uniform(0.0, 70.0, len(episodes))  # (the onsets lie in 0-60 s: some windows over, some not)
    args = (
        np.concatenate([ep[0] for ep in episodes]),
        np.concatenate([ep[1] for ep in episodes]),
        starts,
        band.lower_bound_m,
        band.upper_bound_m,
        True,
        np.array([scores.KINDS.index(s.kind) for s in stims], dtype=np.int64),
        np.array([s.result for s in stims], dtype=np.int64),
        np.array([s.reaction_time_s for s in stims]),
        np.array([s.onset_s for s in stims]),
        stim_starts,
        t_end,
        core.spec.max_reaction_time_s,
    )
    expected = []
    for (lon, off, stimuli), end in zip(episodes, t_end, strict=True):
        core.world.t_s = float(end)
        lat = np.maximum(np.maximum(0.0, band.lower_bound_m - off), off - band.upper_bound_m)
        core.state = PlatoonState(stimuli=stimuli, lon_dev=list(lon), lat_dev=list(lat))
        expected.append(core.metrics())
    assert any(np.isfinite(m["stimulus_mean_rt_s"]) for m in expected) and any(m["lateral_outside_fraction"] > 0 for m in expected)
    window = core.spec.max_reaction_time_s
    assert any(s.result == 0 and end - s.onset_s > window for ep, end in zip(episodes, t_end, strict=True) for s in ep[2])
    for run in (scores.platoon_scores.py_func, None):  # as Python, then compiled
        if run is None:
            scores.platoon_scores(*args, np.empty((len(episodes), len(scores.KEYS))))
            wait_compiled()
            run = scores.platoon_scores
        out = np.full((len(episodes), len(scores.KEYS)), -1.0)
        run(*args, out)
        for j, want in enumerate(expected):
            assert list(want) == list(scores.KEYS)
            got = dict(zip(scores.KEYS, out[j].tolist()))
            assert np.array_equal(list(got.values()), list(want.values()), equal_nan=True), (j, got, want)
    env.close()


def test_compiled_scoring_runs_from_numbas_cache() -> None:
    """Processes that load the compiled sum from numba's cache (the second here at the
    latest) get numpy's sum of 5,000 values. (numba's cache loads a kernel calling a
    recursive one broken, numba issue 6061: with a recursive sum this crashed.)"""
    code = (
        "import numpy as np\nfrom opends_gym.jit import wait_compiled\nfrom opends_gym.metrics.sums import np_sum\n"
        "g = np.random.default_rng(1).standard_normal(5000) * 10.0 ** np.random.default_rng(2).integers(-8, 9, 5000)\n"
        "np_sum(g, 0, 3)\nwait_compiled()\nassert np_sum(g, 0, 5000) == np.sum(g)\nprint('ok')"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    for _ in range(2):
        run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
        assert run.returncode == 0 and run.stdout.strip() == "ok", (run.returncode, run.stderr[-2000:])
