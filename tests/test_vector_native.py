"""The natively batched vector envs (`vector_entry_point`): same results as the single env."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the ids)
from opends_gym.jit import kernel, py_hypot
from opends_gym.vector import NativeVectorEnv
from opends_gym.vector.kernels import CHUNK_ENVS
from opends_gym.vector.platoon_controls import PARALLEL_CONTROLS_ENVS, step_controls, step_controls_parallel

LCT = "OpenDS/LaneChangeTest-v0"
BRAKE = "OpenDS/BrakeReaction-v0"
PLATOON = "OpenDS/ThreeVehiclePlatoon-v0"
SHORT = {
    LCT: {"signs": 3, "lead_in_m": 100.0, "lead_out_m": 60.0},
    BRAKE: {"stimuli": 3, "track_seed": 3, "max_episode_s": 40.0},  # brake sign at 300 m, emergency brake at 586 m
    PLATOON: {"stimuli": 5, "lead_in_m": 100.0, "spacing_min_m": 200.0, "spacing_max_m": 220.0, "max_episode_s": 24.0},
}
Policy = Callable[[np.ndarray, np.random.Generator, int], np.ndarray]


def lct_driver(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Follows the sign's lane (env 0 steers at random and leaves the road), brakes now and then."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 0] = np.clip(0.04 * obs[:, -2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1) + rng.normal(0, 0.02, n)
    a[0, 0] = rng.uniform(-0.3, 0.3)
    a[:, 1] = np.where(rng.random(n) < 0.05, -0.6, 0.0)
    return a


def follow_driver(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Keeps the lane and ~70 km/h, brakes at random and for brake lights; presses buttons at random."""
    width = obs.shape[1]
    steer = np.clip(-0.05 * obs[:, 2] - 0.8 * obs[:, 1] - 0.1 * obs[:, 6], -1, 1)
    pedal = np.clip(0.4 * (19.4 - obs[:, 0]), -1, 1)
    lead_brake = obs[:, 7 + 4 * 6 + 2] > 0
    pedal = np.where(lead_brake | (rng.random(n) < 0.04), -0.8, pedal)
    if width == 7 + 24 + 7:  # the brake test's sign slot
        pedal = np.where((obs[:, -1] > 0) & (obs[:, 0] > 9.0), -0.7, pedal)
    a = np.zeros((n, 6 if width == 7 + 24 + 6 else 2), dtype=np.float32)
    a[:, 0], a[:, 1] = steer + rng.normal(0, 0.01, n), pedal
    if a.shape[1] == 6:
        a[:, 2:] = np.where(rng.random((n, 4)) < 0.15, 1.0, -1.0)
    return a


def _same(tag: str, a: Any, b: Any) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), f"{tag}: native {a!r} != single {b!r}"


def _compare_infos(t: int, native: dict[str, Any], sync: dict[str, Any], n: int) -> None:
    for key, value in sync.items():
        if key in ("events", "_events"):
            continue  # the native batch does not produce the event log
        if key == "episode_metrics":
            for e in np.flatnonzero(sync["_episode_metrics"]):
                for mk, mv in value.items():
                    if not mk.startswith("_"):
                        _same(f"step {t} env {e} metric {mk}", native["episode_metrics"][mk][e], mv[e])
            continue
        _same(f"step {t} info {key}", native[key], value)


def run_identity(env_id: str, policy: Policy, n: int, steps: int, seed: int = 7, **kwargs: Any) -> dict[str, int]:
    """Step the native batch and Gymnasium's SyncVectorEnv of single envs in lockstep; compare everything."""
    kw = {**SHORT[env_id], **kwargs}
    native = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    sync = gym.make_vec(env_id, num_envs=n, vectorization_mode="sync", **kw)
    assert isinstance(native.unwrapped, NativeVectorEnv)
    rng = np.random.default_rng(seed)
    obs, info = native.reset(seed=seed)
    obs_s, info_s = sync.reset(seed=seed)
    _same("reset obs", obs, obs_s)
    _compare_infos(-1, info, info_s, n)
    seen = {"episodes": 0, "reactions": 0, "correct": 0, "ttc_under_3s": 0, "lanes_unknown": 0}
    for t in range(steps):
        a = policy(obs, rng, n)
        obs, r, term, trunc, info = native.step(a)
        obs_s, r_s, term_s, trunc_s, info_s = sync.step(a)
        _same(f"step {t} obs", obs, obs_s)
        _same(f"step {t} reward", r, r_s)
        _same(f"step {t} terminated", term, term_s)
        _same(f"step {t} truncated", trunc, trunc_s)
        _compare_infos(t, info, info_s, n)
        seen["episodes"] += int(np.sum(term | trunc))
        seen["reactions"] += int(np.count_nonzero(info["reaction_result"]))
        seen["correct"] += int(np.count_nonzero(info["reaction_result"] == 1))
        seen["ttc_under_3s"] += int(np.count_nonzero(info["ttc_s"] < 3.0))
        seen["lanes_unknown"] += int(np.count_nonzero(~info["lanes_known"]))
    native.close()
    sync.close()
    return seen


def test_lane_change_test_identical_to_single_env() -> None:
    seen = run_identity(LCT, lct_driver, n=3, steps=560)
    assert seen["episodes"] >= 3 and seen["correct"] >= 3  # ends (off road, end of track), autoresets, lane changes


def hard_left(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Every env but env 0 (straight on) steers off the road the same way, so their episodes end
    on the same steps."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[1:, 0] = 0.5
    return a


def test_episodes_ending_together_report_the_single_envs_metrics() -> None:
    """The episode metrics of several envs that end on one step are gathered together (a
    column per metric); each env's equal the single env's, and the other envs have none."""
    seen = run_identity(LCT, hard_left, n=5, steps=40)
    assert seen["episodes"] >= 8  # (at least two steps on which four ended)


def full_lock(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Full lock left from the reset on with a little throttle (env 0 steers straight on): the
    car spins and its circle takes it behind its start line."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[1:, 0] = 1.0
    a[:, 1] = 0.3
    return a


def test_a_car_behind_its_start_line_reports_lanes_known_as_the_single_env() -> None:
    """Behind the point where the task's lanes begin (here: the start line, s < 0) the single
    env reports `lanes_known` False (`RoadGuide.lanes_known_at`); the batch does too, per env,
    and back on True once the car is in front of it again (observations, infos, metrics equal)."""
    seen = run_identity(LCT, full_lock, n=3, steps=45)
    assert seen["lanes_unknown"] >= 2 * 20  # the two spinning cars: ~28 steps each behind the line


def unclipped(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Float64 actions outside [-1, 1] now and then, pedals of -0.0 and +0.0 (the batch's
    compiled conversion must give the single env's clipped floats and zero pedals); env 0
    steers off the road."""
    a = np.zeros((n, 2))
    a[:, 0] = np.where(rng.random(n) < 0.1, rng.choice([-2.5, 2.5], n), rng.normal(0, 0.02, n) - 0.5 * obs[:, 1])
    a[:, 1] = rng.choice([-3.0, -0.0, 0.0, 0.4, 1.0, 7.0], n)
    a[0, 0] = 0.5  # (env 0 leaves the road: resets)
    return a


def test_actions_beyond_the_box_and_signed_zero_pedals_as_the_single_env() -> None:
    seen = run_identity(LCT, unclipped, n=4, steps=80)
    assert seen["episodes"] >= 1


def straight_on(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """Holds the wheel straight (the LCT starts aligned with the road), braking now and then."""
    a = np.zeros((n, 2), dtype=np.float32)
    a[:, 1] = np.where(rng.random(n) < 0.2, -0.3, 0.0)
    return a


def test_lane_change_test_with_long_policy_steps_identical_to_single_env() -> None:
    """A policy step of 300 physics steps (more than a trace block of 256 holds) runs in parts,
    with trigger boxes touched and timers scored inside them, to the end of the track; scored
    with ISO 26022's segments as well."""
    seen = run_identity(LCT, straight_on, n=3, steps=14, policy_hz=0.2, scoring="iso26022")  # (the ISO keys too)
    assert seen["episodes"] >= 3 and seen["reactions"] >= 3


def tailgating(obs: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """`follow_driver`, except that env 1 overtakes the lead in the left lane (which ends the
    episode) and the last env keeps full throttle behind it (short TTCs, a collision)."""
    a = follow_driver(obs, rng, n)
    a[1, 0] = np.clip(-0.05 * (obs[1, 3] - 1.875) - 0.8 * obs[1, 1], -1, 1)
    a[1:, 1] = 1.0
    return a


def test_brake_reaction_identical_to_single_env() -> None:
    seen = run_identity(BRAKE, tailgating, n=3, steps=230, policy_hz=5)
    assert seen["episodes"] >= 2 and seen["reactions"] >= 1  # the brake sign's timer
    assert seen["ttc_under_3s"] >= 2  # the TTC reward shaping was exercised (the tailgater closes in fast: 2 steps of 0.2 s)


def test_platoon_identical_to_single_env() -> None:
    seen = run_identity(PLATOON, follow_driver, n=2, steps=500, policy_hz=20)
    assert seen["episodes"] >= 2


def test_vector_api_spaces_and_info_batching() -> None:
    env = gym.make_vec(LCT, num_envs=4, vectorization_mode="vector_entry_point")
    single = gym.make(LCT)
    assert env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    assert env.single_observation_space == single.observation_space and env.single_action_space == single.action_space
    assert env.observation_space.shape == (4, *single.observation_space.shape) and env.action_space.shape == (4, 2)
    obs, info = env.reset(seed=[1, 2, 3, 4])
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    for key in ("sim_time_s", "speed_kmh", "lane_index", "reaction_result", "mean_deviation_m", "headway_s"):
        assert info[key].shape == (4,) and info[f"_{key}"].all()
    assert info["lane_index"].dtype == np.int64 and info["speed_kmh"].dtype == np.float64
    obs, reward, term, trunc, info = env.step(env.action_space.sample())
    assert reward.shape == (4,) and reward.dtype == np.float64 and term.dtype == bool and trunc.dtype == bool
    assert env.observation_space.contains(obs)
    assert "episode_metrics" not in info
    with pytest.raises(ValueError, match="4 seeds"):
        env.reset(seed=[1, 2])
    env.close()


def test_deterministic_and_seeded_like_sync() -> None:
    def rollout() -> list[np.ndarray]:
        env = gym.make_vec(LCT, num_envs=3, vectorization_mode="vector_entry_point", **SHORT[LCT])
        rng = np.random.default_rng(3)
        obs, _ = env.reset(seed=42)
        out = [obs]
        for _ in range(60):
            obs, r, *_ = env.step(lct_driver(obs, rng, 3))
            out += [obs, r]
        return out

    a, b = rollout(), rollout()
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    # reset(seed=s) seeds env i with s + i, as SyncVectorEnv: env 1 of seed 42 is a single env seeded 43
    env = gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point")
    single = gym.make(LCT)
    obs, _ = env.reset(seed=42)
    assert np.array_equal(obs[1], single.reset(seed=43)[0])


def test_bullet_render_and_reset_mask_are_refused_clearly() -> None:
    with pytest.raises(ValueError, match=r"physics='fast' only.*vectorization_mode='sync'"):
        gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", physics="bullet")
    with pytest.raises(ValueError, match="does not render"):
        gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", render_mode="rgb_array")
    with pytest.raises(TypeError, match="polcy_hz"):
        gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", polcy_hz=20)
    with pytest.raises(MemoryError, match="record_metrics=False"):  # refused before anything is allocated
        gym.make_vec(LCT, num_envs=10**7, vectorization_mode="vector_entry_point")
    env = gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="reset_mask"):
        env.reset(options={"reset_mask": np.array([True, False])})


def test_nan_action_names_the_env() -> None:
    env = gym.make_vec(PLATOON, num_envs=3, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    a = np.zeros((3, 6), dtype=np.float32)
    a[2, 1] = np.nan
    with pytest.raises(ValueError, match="env 2: action contains NaN"):
        env.step(a)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros((3, 2), dtype=np.float32))


def test_nan_action_in_a_parallel_batch_names_the_first_env() -> None:
    """A large batch checks its actions on the threads: the error still names the first env
    with a bad action, nothing is stepped, and the next good step runs."""
    n = PARALLEL_CONTROLS_ENVS
    env = gym.make_vec(PLATOON, num_envs=n, vectorization_mode="vector_entry_point", record_metrics=False)
    env.reset(seed=0)
    a = np.zeros((n, 6), dtype=np.float32)
    a[n - 1, 0] = np.nan
    a[3 * CHUNK_ENVS + 5, 1] = np.inf
    with pytest.raises(ValueError, match=f"env {3 * CHUNK_ENVS + 5}: action contains NaN or infinity"):
        env.step(a)
    a[:, 0], a[:, 1] = 0.0, 0.5
    obs, _, _, _, info = env.step(a)
    assert obs.shape[0] == n and np.isfinite(obs).all()
    small = gym.make_vec(PLATOON, num_envs=2, vectorization_mode="vector_entry_point", record_metrics=False)
    small.reset(seed=0)
    _, _, _, _, once = small.step(a[:2])  # (one step from the reset: the refused one moved no env)
    assert np.all(info["sim_time_s"] == once["sim_time_s"][0]) and once["sim_time_s"][0] > 0.0


def test_parallel_controls_are_the_serial_ones() -> None:
    """`step_controls_parallel` writes what `step_controls` writes (steering and pedals
    clipped and split, the reaction button's edge, the buttons held, the indicator)."""
    rng = np.random.default_rng(3)
    n = 5 * CHUNK_ENVS + 17
    a = rng.choice([-1.5, -1.0, -0.3, 0.0, 0.4, 1.0, 2.0], size=(n, 6))
    stepping = rng.random(n) < 0.8
    held = rng.random((n, 4)) < 0.5
    outs = []
    for controls in (step_controls, step_controls_parallel):
        arrays = (held.copy(), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64))
        assert controls(a, stepping, True, *arrays) == -1
        outs.append(arrays)
    for serial, parallel in zip(*outs, strict=True):
        assert np.array_equal(serial, parallel)
    assert outs[0][4].any() and outs[0][5].any()  # (edges and indicators occurred: the comparison covers them)


def test_without_metrics_the_same_steps() -> None:
    kw = {**SHORT[LCT], "max_episode_s": 3.0}
    with_m = gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", **kw)
    without = gym.make_vec(LCT, num_envs=2, vectorization_mode="vector_entry_point", record_metrics=False, **kw)
    assert np.array_equal(with_m.reset(seed=1)[0], without.reset(seed=1)[0])
    for _ in range(30):  # 3 s at 10 Hz: truncated at the 30th step
        act = np.tile(np.array([[0.0, 0.0]], dtype=np.float32), (2, 1))
        oa, ra, _, ta, ia = with_m.step(act)
        ob, rb, _, tb, ib = without.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb) and np.array_equal(ta, tb)
    assert ta.all() and "episode_metrics" in ia and "episode_metrics" not in ib


@kernel
def _kernel_math(x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    for i in range(len(x)):
        a, b = x[i], y[i]
        out[0, i], out[1, i], out[2, i], out[3, i] = math.tanh(a), math.atan(a), math.tan(a), math.atan2(a, b)
        out[4, i], out[5, i], out[6, i], out[7, i] = math.sin(a), math.cos(a), a % b, py_hypot(a, b)


def test_kernel_math_equals_python_math() -> None:
    """The single env and the native batch share compiled kernels; those (and the Python code
    that was there before them) must compute what Python's `math` computes, bit for bit."""
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-1, 1, 20000), rng.uniform(-50, 50, 20000), rng.normal(0, 1e-4, 5000), [0.0, -0.0, 1e-310]])
    y = np.concatenate([rng.uniform(-1, 1, 20000), rng.uniform(-50, 50, 20000), rng.normal(0, 1e-4, 5000), [1.0, 3.0, 4e-310]])
    out = np.empty((8, len(x)))
    _kernel_math(x, y, out)
    refs = (math.tanh, math.atan, math.tan, math.atan2, math.sin, math.cos, lambda a, b: a % b, math.hypot)
    for k, ref in enumerate(refs):
        expect = [ref(a, b) if k in (3, 6, 7) else ref(a) for a, b in zip(x.tolist(), y.tolist())]
        assert np.array_equal(out[k], np.array(expect)), k


def _rollout(env: Any, steps: int, seed: int) -> list[tuple[Any, ...]]:
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    out: list[tuple[Any, ...]] = [(obs, info)]
    for _ in range(steps):
        out.append(env.step(lct_driver(obs, rng, env.num_envs)))
        obs = out[-1][0]
    return out


@pytest.mark.parametrize("shards", [{"threads": 2}, {"processes": 2}])
def test_sharded_batches_step_exactly_like_one_shard(shards: dict[str, int]) -> None:
    """Threads or worker processes change where envs are stepped, not what they compute:
    observations, rewards, flags, info arrays and episode metrics (with autoresets) equal the
    unsharded batch's; errors name the env in the whole batch."""
    kw = {**SHORT[LCT], "max_episode_s": 8.0}
    one = gym.make_vec(LCT, num_envs=5, vectorization_mode="vector_entry_point", threads=1, **kw)
    sharded = gym.make_vec(LCT, num_envs=5, vectorization_mode="vector_entry_point", **shards, **kw)
    assert len(sharded.unwrapped.shards) == 2
    ends = 0
    for t, (a, b) in enumerate(zip(_rollout(one, 120, 3), _rollout(sharded, 120, 3), strict=True)):
        for x, y in zip(a[:-1], b[:-1], strict=True):
            _same(f"step {t}", x, y)
        info_a, info_b = a[-1], b[-1]
        assert info_a.keys() == info_b.keys()
        for key, value in info_a.items():
            if key == "episode_metrics":
                ends += int(info_a["_episode_metrics"].sum())
                for mk in value:
                    _same(f"step {t} metric {mk}", info_b[key][mk], value[mk])
            else:
                _same(f"step {t} info {key}", info_b[key], value)
    assert ends >= 5  # episodes ended (off the road or at 8 s) and were reset in both
    a = np.zeros((5, 2), dtype=np.float32)
    a[4, 0] = np.nan
    with pytest.raises(ValueError, match="env 4: action contains NaN"):
        sharded.step(a)
    if "processes" in shards:  # a worker that dies is reported, not waited for
        worker = sharded.unwrapped.shards[1]._process
        worker.kill()
        worker.join()
        with pytest.raises(RuntimeError, match="native batch worker 1 died"):
            sharded.step(np.zeros((5, 2), dtype=np.float32))
    one.close()
    sharded.close()


def test_many_chunks_step_each_env_as_alone() -> None:
    """A batch large enough that its kernels split it into chunks stepped on numba's threads
    computes for each env what a batch of that env alone computes (observations, rewards,
    flags, info and episode metrics, through autoresets); what a step returns is the caller's
    (the next step leaves it unchanged)."""
    assert _chunks_as_alone(LCT, lct_driver, {**SHORT[LCT], "max_episode_s": 8.0}, steps=120) >= 3


@pytest.mark.parametrize("env_id", [BRAKE, PLATOON])
def test_brake_and_platoon_batches_over_chunks_step_each_env_as_alone(env_id: str) -> None:
    """The brake and platoon batches, over more envs than one chunk, give each env what a
    batch of that env alone gives (stimuli, traffic, autoresets and episode metrics included)."""
    assert _chunks_as_alone(env_id, follow_driver, {**SHORT[env_id], "max_episode_s": 16.0, "policy_hz": 5}, steps=90) >= 3


def _chunks_as_alone(env_id: str, driver: Policy, kw: dict[str, Any], steps: int) -> int:
    """Steps a batch of 2 chunks + 3 envs and one of 3 of its envs (first, in the middle chunk,
    last) in lockstep, the middle one steered off the road now and then; compares every
    output of the three. Returns the episodes that ended among them."""
    from opends_gym.vector.kernels import CHUNK_ENVS

    n = 2 * CHUNK_ENVS + 3
    picks = [0, CHUNK_ENVS + 1, n - 1]
    big = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    small = gym.make_vec(env_id, num_envs=len(picks), vectorization_mode="vector_entry_point", **kw)
    seeds = [100 + i for i in range(n)]
    obs, _ = big.reset(seed=seeds)
    obs_s, _ = small.reset(seed=[seeds[e] for e in picks])
    _same("reset obs", obs[picks], obs_s)
    rng = np.random.default_rng(5)
    ends = 0
    held: tuple[Any, ...] = ()
    for t in range(steps):
        a = driver(obs, rng, n)
        a[picks[1], 0] = rng.uniform(-0.4, 0.4)  # (off the road: an early end in a middle chunk)
        out = big.step(a)
        out_s = small.step(a[picks])
        for x, kept in held:  # the arrays a step returned stay as they were (none is the batch's state)
            _same(f"step {t - 1} kept", x, kept)
        held = tuple((x, x.copy()) for x in (*out[:4], *(v for v in out[4].values() if isinstance(v, np.ndarray))))
        obs = out[0]
        for name, x, y in zip(("obs", "reward", "terminated", "truncated"), out[:4], out_s[:4], strict=True):
            _same(f"step {t} {name}", x[picks], y)
        info, info_s = out[4], out_s[4]
        for key, value in info_s.items():
            if key == "episode_metrics":
                ends += int(info_s["_episode_metrics"].sum())
                for mk, mv in value.items():
                    _same(f"step {t} metric {mk}", info[key][mk][picks], mv)
            else:
                _same(f"step {t} info {key}", info[key][picks], value)
    big.close()
    small.close()
    return ends
