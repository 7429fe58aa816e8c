"""A virtual participant following a steady lead has its foot on the accelerator when the
lead brakes, as drivers do (holding speed needs throttle against drag), so its brake trials
are valid (`metrics.reaction.score_brake_trials`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import opends_gym  # noqa: F401
from opends_gym.drivers.participant import ParticipantDriver
from opends_gym.drivers.population import sample_population
from opends_gym.metrics.reaction import ACCELERATOR_ON

STEADY_S = 3.0  # following: the gap changed less than STEADY_GAP_M over this long before the brake onset
STEADY_GAP_M = 3.0


def _steady_onsets(seed: int) -> tuple[int, int]:
    """(lead brake onsets after steady following, those with the accelerator pressed)."""
    env = gym.make("OpenDS/BrakeReaction-v0", stimuli=6)
    obs, info = env.reset(seed=seed)
    driver = ParticipantDriver(env, sample_population(seed + 1)[seed], "baseline", seed=seed)
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(driver.act(obs, info))
        done = term or trunc
    base = env.unwrapped
    tr = base.trace  # type: ignore[attr-defined]
    t, acc, g = tr.col("t_s"), tr.col("accelerator"), tr.col("gap_m")
    steady = pressed = 0
    for st in base.platoon.state.stimuli:  # type: ignore[attr-defined]
        if st.kind not in ("brakeLight", "emergencyBrake"):
            continue
        before = (t > st.onset_s - STEADY_S) & (t <= st.onset_s)
        gap = g[before]
        if not before.any() or not np.all(np.isfinite(gap)) or gap.max() - gap.min() >= STEADY_GAP_M:
            continue
        steady += 1
        k = int(np.searchsorted(t, st.onset_s, side="right")) - 1
        pressed += int(acc[k] > ACCELERATOR_ON)
    env.close()
    return steady, pressed


def test_participant_following_a_steady_lead_holds_the_accelerator_at_brake_onset() -> None:
    counts = [_steady_onsets(seed) for seed in range(8)]
    steady = sum(c[0] for c in counts)
    pressed = sum(c[1] for c in counts)
    assert steady >= 8  # the drives do include steady following before a lead brakes
    assert pressed >= 0.9 * steady, f"accelerator pressed at {pressed} of {steady} steady-following onsets"
