"""Recovery augmentation (`export --augment recovery`, `data.recovery`): perturbed states of a logged
drive are labelled with the action that takes the car back to the log's path and speed.

The "log" here is the env's own car driven from the Countryside task's start with full gas for 4 s,
then straight on with a constant pedal: from a state on it, holding the log's action reproduces the
log, so a label there can be compared with the log's action.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from opends_gym.cli.main import main
from opends_gym.data.episodes import make_env
from opends_gym.data.recovery import RecoveryConfig, RecoveryLabeler, Reference, perturbed_pose, recovery_copy
from opends_gym.sim.controls import DriverControls

from .conftest import DRIVES

TASK = DRIVES / "Countryside"
LOGGED = np.asarray([0.0, 0.35], dtype=np.float32)  # the log's steering and pedal after its first 4 s
SHORT_LOG = DRIVES / "drives" / "2019_01_04-11_26_07" / "carData(2).txt"  # a real log: 4 s, 28 m from its first gas


@pytest.fixture(scope="module")
def logged() -> Any:
    """The env (its road exits not ending an episode) and a 10 s reference driven in it with LOGGED."""
    env = make_env("OpenDS/DrivingTask-v0", {"task": str(TASK), "action": "continuous", "on_road_exit": "continue"})
    env.reset(seed=0)
    base: Any = env.unwrapped
    base.turn_engine_key(True)  # the task starts with the engine off
    rows = []
    pedal = np.where(np.arange(100) < 40, 1.0, LOGGED[1])
    for p in pedal:
        s = base.world.ego.state
        rows.append((base.world.t_s, s.x, s.y, s.z, s.yaw, s.u))
        env.step(np.asarray([LOGGED[0], p], dtype=np.float32))
    t, x, y, z, yaw, u = np.asarray(rows).T
    ref = Reference(t, x, y, z, yaw, u, np.full(len(t), LOGGED[0]), pedal, np.ones(len(t)))
    yield env, ref
    env.close()


def _label(env: Any, ref: Reference, lateral_m: float = 0.0, speed_factor: float = 1.0, at_s: float = 6.0) -> np.ndarray:
    """The recovery label of the logged state at `at_s`, shifted left by `lateral_m` and its speed scaled."""
    env.reset(seed=0, options={"start_pose": perturbed_pose(ref.at_time(at_s), lateral_m, 0.0, speed_factor)})
    env.unwrapped.world.ego.inputs.steering = float(LOGGED[0])
    return RecoveryLabeler(env, ref).label(int(np.searchsorted(ref.t[ref.rows], at_s)))[0]


def test_a_state_on_the_log_is_labelled_with_the_logs_action(logged: Any) -> None:
    env, ref = logged
    assert ref.at_time(6.0)["u"] > 10.0  # it drives
    on = _label(env, ref)
    assert on[1] == pytest.approx(LOGGED[1], abs=0.1)
    assert on[0] == pytest.approx(LOGGED[0], abs=0.02)


def test_slower_than_the_log_gets_more_pedal_and_faster_less(logged: Any) -> None:
    env, ref = logged
    on = _label(env, ref)[1]
    assert _label(env, ref, speed_factor=0.7)[1] > on + 0.2 and _label(env, ref, speed_factor=0.7)[1] > LOGGED[1]
    assert _label(env, ref, speed_factor=1.3)[1] < min(on, LOGGED[1]) - 0.2  # off the gas or braking


def test_left_of_the_path_steers_right_and_right_of_it_left(logged: Any) -> None:
    env, ref = logged
    on = _label(env, ref)[0]
    assert _label(env, ref, lateral_m=1.5)[0] < on - 0.005  # + is left (OpenDS's steering sign)
    assert _label(env, ref, lateral_m=-1.5)[0] > on + 0.005


def test_a_recovery_copy_returns_to_the_path_and_the_speed(logged: Any) -> None:
    env, ref = logged
    start = np.asarray([1.5, 0.05, 0.6])  # 1.5 m left, turned further left, 40 % slower
    ep = recovery_copy(env, ref, 4.0, None, start, "log#recovery0", RecoveryConfig(horizon_s=4.0))
    assert ep is not None and ep.kind == "recovery" and ep.steps == 40
    base: Any = env.unwrapped
    s = base.world.ego.state
    _, across, _ = ref.locate(s.x, s.z, 0)
    assert abs(across) < 0.5  # from 1.5 m
    assert ep.infos["speed_kmh"][-1] / 3.6 == pytest.approx(ref.at_time(8.0)["u"], rel=0.15)  # from 60 % of it


def test_a_keyboard_taps_steering_as_the_guess_still_rejoins_the_path_ahead(logged: Any) -> None:
    env, ref = logged
    tapped = Reference(ref.t, ref.x, ref.y, ref.z, ref.yaw, ref.u, np.full(len(ref.t), -0.9), ref.pedal, ref.engine_on)
    env.reset(seed=0, options={"start_pose": perturbed_pose(ref.at_time(6.0), 0.5, 0.0, 1.0)})  # 0.5 m left of the path
    base: Any = env.unwrapped
    label = RecoveryLabeler(env, tapped).label(int(np.searchsorted(ref.t[ref.rows], 6.0)))[0]
    s = base.world.ego.state
    x, z, _ = base.world.ego.ahead(base.world.dt_s, DriverControls.pedals(float(label[0]), max(float(label[1]), 0.0), 0.0).clipped(), 120)
    along, across, _ = ref.locate(x, z, 0)
    assert abs(label[0]) < 0.1  # a gentle turn, not a circle near the guess (before: -0.82, round onto the path behind)
    assert along - ref.locate(s.x, s.z, 0)[0] > 0.8 * s.u * 2.0 and abs(across) < 0.5


def test_a_dart_rollout_is_driven_with_noise_and_records_the_labels(logged: Any) -> None:
    env, ref = logged
    config = RecoveryConfig(dart_steering=0.2, dart_pedal=0.2)
    start = np.asarray([0.0, 0.0, 1.0])  # on the log
    clean = recovery_copy(env, ref, 4.0, None, start, "log#recovery0", config, horizon_s=0.1)  # one step, no noise
    ep = recovery_copy(env, ref, 4.0, None, start, "log#dart0", config, horizon_s=4.0, noise=np.random.default_rng(0))
    assert clean is not None and ep is not None and ep.kind == "dart" and ep.steps == 40
    np.testing.assert_array_equal(ep.actions[0], clean.actions[0])  # the state's label is recorded ...
    assert abs(ep.observations[1][5] - clean.observations[1][5]) > 0.01  # ... the wheel was moved with the noise
    s = env.unwrapped.world.ego.state
    assert abs(ref.locate(s.x, s.z, 0)[1]) < 1.0  # and the labels kept the car near the path


def test_the_car_model_look_ahead_is_the_cars_own_steps(logged: Any) -> None:
    env, _ = logged
    env.reset(seed=0)
    ego = env.unwrapped.world.ego
    dt = env.unwrapped.world.dt_s
    c = DriverControls.pedals(0.1, 0.4, 0.0).clipped()
    ahead = ego.ahead(dt, c, 90)
    assert (ego.state.x, ego.state.u) == (env.unwrapped.world.ego.state.x, 0.0)  # put back
    for _ in range(90):
        ego.step(dt, c)
    assert ahead == pytest.approx((ego.state.x, ego.state.z, ego.state.u), abs=1e-9)


def test_export_augment_recovery_adds_labelled_copies(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(
            [
                "export",
                str(SHORT_LOG),
                "--task",
                str(TASK),
                "--trim-idle",
                "--augment",
                "recovery",
                "--augment-every",
                "2",
                "--augment-draws",
                "2",
                "--augment-dart",
                "1",
                "--augment-lateral",
                "0.5",
                "--minari",
                "test/aug",
            ]
        )
    assert code == 0, err.getvalue()
    import minari

    ds = minari.load_dataset("test/aug-v0")
    meta = list(ds.storage.get_episode_metadata(ds.episode_indices))
    kinds = [m["kind"] for m in meta]
    assert kinds[0] == "cardata" and kinds[-1] == "dart" and kinds.count("recovery") == len(kinds) - 2 >= 2
    copies = [m for m in meta if m["kind"] == "recovery"]
    for a, b in zip(copies[::2], copies[1::2], strict=True):  # two draws from each start point: two perturbations
        assert a["start_pose/x"] != b["start_pose/x"] and abs(a["start_pose/x"] - b["start_pose/x"]) <= 1.0  # each within 0.5 m
    assert "recovery copies and rollouts" in err.getvalue()
    fake = tmp_path / "drive.mcap"
    fake.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 16)
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["export", str(fake), "--augment", "recovery", "--minari", "test/aug2"])
    assert code == 2
    assert err.getvalue().strip().endswith("recovery copies are made of OpenDS carData.txt logs, not of MCAP recordings")


def test_export_refuses_no_draws_in_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["export", str(SHORT_LOG), "--task", str(TASK), "--augment", "recovery", "--augment-draws", "0", "--minari", "test/a"])
    assert code == 2
    assert err.getvalue().strip().endswith("--augment-draws must be at least 1 and --augment-dart 0 or more, not 0, 0")


def test_export_augment_options_default_to_the_recovery_config() -> None:
    from opends_gym.cli.export import RECOVERY_LATERAL_M, RECOVERY_TAU_S

    assert (RecoveryConfig().lateral_m, RecoveryConfig().tau_s) == (RECOVERY_LATERAL_M, RECOVERY_TAU_S)


def test_export_refuses_a_horizon_out_of_range_in_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["export", str(SHORT_LOG), "--task", str(TASK), "--augment", "recovery", "--augment-tau", "0", "--minari", "test/a"])
    assert code == 2
    assert err.getvalue().strip().endswith("--augment-tau must be 0.1-10 s, not 0")
