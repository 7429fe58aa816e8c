"""`--json` outputs are strict JSON: metrics that are NaN or infinite come out as null."""

from __future__ import annotations

import json

import pytest

from opends_gym.cli.main import main as cli
from opends_gym.jsonsafe import json_safe


def _strict(text: str) -> object:
    def refuse(name: str) -> None:
        raise AssertionError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_run_json_has_no_nan(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli(["run", "OpenDS/ReactionTest-v0", "--agent", "rule", "--max-seconds", "3", "--json"]) == 0
    out = _strict(capsys.readouterr().out)
    assert isinstance(out, dict)
    episode = out["episodes"][0]
    assert episode["mean_headway_s"] is None and episode["min_ttc_s"] is None  # no lead car: NaN and inf
    assert episode["distance_m"] > 0


def test_json_safe_converts_numpy_and_non_finite_values() -> None:
    import numpy as np

    value = {"a": float("nan"), "b": [float("inf"), np.float32(1.5)], "c": np.int64(3), 4: (True, None)}
    assert json_safe(value) == {"a": None, "b": [None, 1.5], "c": 3, "4": [True, None]}
