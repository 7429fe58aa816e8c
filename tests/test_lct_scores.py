"""The native LCT batch's compiled episode scoring (`metrics.lct_scores`): the single env's floats."""

from __future__ import annotations

import numpy as np

from tests.test_vector_native import LCT, run_identity

SWERVE_AT_M = np.array([np.inf, -1.0, 38.0, 30.0, 22.0, 12.0, -1.0, np.inf])  # distance to the revealed sign


def keeper_with_swerves(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Keeps the sign's lane, except that env k steers hard off the road once its revealed
    sign is nearer than SWERVE_AT_M[k] (inf: at once; -1: never), so episodes end before the
    first sign is readable and inside instructed lane changes (the signs' start to the end of
    the basic normative change), before passing the sign."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
    swerve = (SWERVE_AT_M[:n] == np.inf) | ((obs[:, -3] > 0) & (obs[:, -1] < SWERVE_AT_M[:n]))
    a[:, 0] = np.where(swerve, 0.5, a[:, 0])
    return a


def test_episodes_ended_before_passing_a_sign_score_as_the_single_env() -> None:
    """Episodes that end before and inside instructed lane changes (scored in compiled code):
    every metric (SAE J2944 SDLP without the instructed changes, reversal rates, sign counts)
    equals the single env's."""
    seen = run_identity(LCT, keeper_with_swerves, n=8, steps=260, seed=3)
    assert seen["episodes"] >= 8 and seen["correct"] >= 2
