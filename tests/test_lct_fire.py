"""The native LCT batch fires its trigger actions inside the compiled pass (`vector.lct_fire`)."""

from __future__ import annotations

from tests.test_vector_native import LCT, lct_driver, run_identity, straight_on


def test_signs_revealed_and_timers_set_up_in_the_compiled_pass_as_the_single_env() -> None:
    """Sign reveals, timer setups, the start and end triggers fired by the compiled pass:
    observations, rewards, reactions and episode metrics equal the single env's."""
    seen = run_identity(LCT, lct_driver, n=2, steps=300, seed=5)
    assert seen["episodes"] >= 2 and seen["correct"] >= 2


def test_timers_that_end_before_the_next_sign_in_one_policy_step_as_the_single_env() -> None:
    """Signs 60-70 m apart and policy steps of 300 physics steps: a trial missed (distance
    limit) and the next sign's timer set up within one policy step, whose result must be
    logged first (Python fires those triggers); the same results as the single env."""
    seen = run_identity(LCT, straight_on, n=3, steps=14, policy_hz=0.2, spacing_min_m=60.0, spacing_max_m=70.0)
    assert seen["episodes"] >= 3 and seen["reactions"] >= 6
