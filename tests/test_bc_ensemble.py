"""`train bc --ensemble N`: N networks trained from their own seeds on the same data; the clone acts
with their mean output (data.bc, drivers.bc). A clone of seed s holds the members of seeds
N*s..N*s+N-1, each the single clone of that seed, so clones of different seeds share none."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from opends_gym.cli.main import main


@pytest.fixture(scope="module")
def clones(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Path], np.ndarray]:
    """An ensemble of 2 (`train bc --ensemble 2`) and the single clones of seeds 0 and 1, of two 2 s
    LCT drives of a participant; and the drives' observations."""
    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.data.episodes import collect, make_env
    from opends_gym.data.minari_io import write_dataset
    from opends_gym.drivers.agents import make_agent

    d = tmp_path_factory.mktemp("ensemble")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MINARI_DATASETS_PATH", str(d / "minari"))
        env = make_env("OpenDS/LaneChangeTest-v0", {"max_episode_s": 2.0})
        episodes = [collect(env, make_agent("participant:1"), seed) for seed in (0, 1)]
        env.close()
        write_dataset("test/ens", episodes)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            assert (
                main(["train", "bc", "test/ens-v0", "--epochs", "5", "--validation", "0", "--ensemble", "2", "--out", str(d / "ens")]) == 0
            )
        for seed in (0, 1):
            train_bc("test/ens-v0", d / f"s{seed}", BCConfig(epochs=5, validation=0.0, seed=seed))
    return d / "ens", [d / "s0", d / "s1"], np.concatenate([np.asarray(ep.observations) for ep in episodes])


def _acts(folder: Path, observations: np.ndarray) -> np.ndarray:
    from opends_gym.drivers.bc import BCDriver

    driver = BCDriver(folder)
    out = []
    for obs in observations:
        driver._obs = []  # a memoryless clone: each observation on its own
        out.append(driver.act(obs, {}))
    return np.asarray(out)


def test_an_ensemble_acts_with_the_mean_of_its_members(clones: tuple[Path, list[Path], np.ndarray]) -> None:
    ensemble, singles, observations = clones
    both = _acts(ensemble, observations)
    members = [_acts(s, observations) for s in singles]
    inside = np.all([np.abs(m) < 0.99 for m in members], axis=0).all(axis=1)  # no member's action clipped at the bounds
    assert inside.sum() >= 10
    assert np.abs(members[0] - members[1])[inside].max() > 2e-4  # the members differ ...
    np.testing.assert_allclose(both[inside], (0.5 * (members[0] + members[1]))[inside], atol=2e-6)  # ... and it acts with their mean


def test_an_ensemble_needs_a_member(tmp_path: Path) -> None:
    from opends_gym.data.bc import BCConfig, train_bc
    from opends_gym.errors import UserError

    with pytest.raises(UserError, match="ensemble must be at least 1 member, not 0"):
        train_bc("test/none-v0", tmp_path / "c", BCConfig(ensemble=0))
