"""Recovery augmentation: perturbed copies of a logged drive, labelled with the action that returns
the car to the logged path and speed (`opends-gym export --augment recovery`).

Why: a clone trained on drives that stay near the lane centre at the logged speed has never seen
what to do when it is off the path or slower than the drive was at that place, and its own small
errors take it there (covariate shift, Ross et al. 2011). Without an expert to ask (DAgger), the
classic remedy synthesises those states and labels them with a recovery: Bojarski et al. 2016
("End to End Learning for Self-Driving Cars", NVIDIA) add shifted and rotated views whose steering
label "would steer the vehicle back to the desired location and orientation in two seconds";
Bansal et al. 2018 (ChauffeurNet) perturb the logged trajectory and train on the recovery back to
it. Here the car model is known and the env deterministic, so the recovery is found by simulating
it, not by a hand-tuned gain:

* the drive is replayed as the export replays it (`episodes.drive`); every `every_s` seconds
  (`--augment-every`) a copy
  starts from the logged state at that time (the carData row, interpolated; the env's world, its
  traffic included, as the replay had it then), shifted across the path by up to `lateral_m`,
  turned by up to `heading_rad` and with its speed scaled by a factor in [1 - `slower`, 1 + `faster`]
  (seeded uniform draws, `seed`: deterministic);
* each copy is driven `horizon_s` seconds through the env with its labels, and each label is the
  action found through the car model (`World.ego` stepped ahead and restored): the pedal (brake
  when negative) that, held `tau_s` seconds, brings the car to the speed the log had at the place
  it reaches then, and the steering that, held `tau_s` seconds, brings it back onto the logged
  path (each a bisection on the simulated outcome; re-planned every step, so the copy follows the
  path as pure pursuit does, through the car's own dynamics). `tau_s` = 2 s is Bojarski's horizon.

The copies are episodes of kind `recovery` beside the drive itself (`demo` episodes are the
person's actions, untouched). The logged path and speed are the log's own rows, not the env's
replay of them: where the replay drifts (the env's flat ground, keyboard taps), the copies still
return to where the person drove.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import UserError
from .episodes import (
    Episode,
    _input_env,
    _policy_hz,
    _start,
    _step,
    cardata_pedal,
    cardata_start_pose,
    cardata_start_row,
    cardata_steps,
    drive,
)

AUGMENTS = ("recovery",)  # `--augment` choices
STEERING_GRID = 17  # steering values tried across [-1, 1] before bisecting (1/8 of the range apart)


@dataclass(frozen=True)
class RecoveryConfig:
    """How the perturbed copies start and how far ahead their labels look (module docstring)."""

    every_s: float = 1.0  # a copy starts every this many seconds of the drive
    horizon_s: float = 3.0  # each copy is driven this long with its recovery labels
    tau_s: float = 2.0  # the label rejoins the logged path and speed within this (Bojarski et al. 2016: 2 s)
    lateral_m: float = 1.5  # start shifted across the path by up to this (either side)
    heading_rad: float = 0.1  # start turned by up to this (either side)
    slower: float = 0.5  # start speed down to (1 - slower) x the logged speed
    faster: float = 0.25  # start speed up to (1 + faster) x the logged speed
    iterations: int = 8  # bisection steps per searched input (2 / 2**8 of its range)
    seed: int = 0
    draws: int = 1  # copies per start point, each with its own perturbation draw
    dart: int = 0  # noisy rollouts of the whole drive with the labels (DART, Laskey et al. 2017)
    dart_steering: float = 0.05  # DART: SD of the Gaussian noise added to the executed steering (of [-1, 1])
    dart_pedal: float = 0.1  # DART: SD of the noise added to the executed pedal


class Reference:
    """A logged drive's path and speed: rows from its start (time s, x, y, z, yaw rad, speed m/s,
    steering, pedal, engine on), and the path without standing rows for locating a car on it."""

    def __init__(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray, yaw: np.ndarray, u: np.ndarray,
                 steering: np.ndarray, pedal: np.ndarray, engine_on: np.ndarray) -> None:  # fmt: skip
        self.t, self.x, self.y, self.z = (np.asarray(v, dtype=float) for v in (t, x, y, z))
        self.yaw = np.unwrap(np.asarray(yaw, dtype=float))
        self.u, self.steering = np.asarray(u, dtype=float), np.asarray(steering, dtype=float)
        self.pedal, self.engine_on = np.asarray(pedal, dtype=float), np.asarray(engine_on, dtype=float)
        keep = [0]
        for i in range(1, len(self.x)):  # a point every 5 cm or more: no zero-length segment
            if math.hypot(self.x[i] - self.x[keep[-1]], self.z[i] - self.z[keep[-1]]) >= 0.05:
                keep.append(i)
        self.rows = np.asarray(keep)
        self.px, self.pz = self.x[self.rows], self.z[self.rows]
        self.s = np.r_[0.0, np.cumsum(np.hypot(np.diff(self.px), np.diff(self.pz)))]
        self.pu = self.u[self.rows]

    @classmethod
    def from_cardata(cls, rec: Any, i0: int) -> Reference:
        """A carData log (`record.conform.Recorded`) from row i0 (its episode's first row)."""
        sl = slice(i0, None)
        return cls(rec.sim_t[sl] - rec.sim_t[i0], rec.x[sl], rec.y[sl], rec.z[sl], rec.yaw[sl], np.maximum(rec.speed_kmh[sl], 0.0) / 3.6,
                   rec.steering[sl], cardata_pedal(rec)[sl], rec.engine_on[sl])  # fmt: skip

    @property
    def moves(self) -> bool:
        return len(self.rows) >= 2

    def at_time(self, t_s: float) -> dict[str, float]:
        """The logged state at `t_s` seconds from the start (linear between rows)."""
        out = {k: float(np.interp(t_s, self.t, getattr(self, k))) for k in ("x", "y", "z", "yaw", "u", "steering")}
        out["engine_on"] = float(self.engine_on[min(int(np.searchsorted(self.t, t_s, side="right")) - 1, len(self.t) - 1)])
        return out

    def locate(self, x: float, z: float, hint: int) -> tuple[float, float, int]:
        """(distance along the path, signed distance across it (+ left), segment) of the nearest
        point of the path to (x, z), searched near segment `hint` (the path may come back on itself);
        the first and last segments extend beyond the path's ends."""
        n = len(self.px) - 1
        lo, hi = max(0, hint - 40), min(n, hint + 400)
        ax, az = self.px[lo:hi], self.pz[lo:hi]
        dx, dz = self.px[lo + 1 : hi + 1] - ax, self.pz[lo + 1 : hi + 1] - az
        length2 = dx * dx + dz * dz
        f = ((x - ax) * dx + (z - az) * dz) / length2
        low, high = np.zeros_like(f), np.ones_like(f)
        if lo == 0:
            low[0] = -np.inf
        if hi == n:
            high[-1] = np.inf
        f = np.clip(f, low, high)
        fx, fz = ax + f * dx, az + f * dz
        i = int(np.argmin(np.hypot(x - fx, z - fz)))
        length = math.sqrt(length2[i])
        # the car's left of a heading (fx, fz) is (fz, -fx) (envs: forward (-sin yaw, -cos yaw), left (-cos yaw, sin yaw))
        across = ((x - fx[i]) * dz[i] - (z - fz[i]) * dx[i]) / length
        return float(self.s[lo + i] + f[i] * length), float(across), lo + i

    def speed_at(self, s_m: float) -> float:
        """The logged speed at `s_m` metres along the path."""
        return float(np.interp(s_m, self.s, self.pu))


class RecoveryLabeler:
    """The recovery action for the env's car now (module docstring), found by simulating its car model."""

    def __init__(self, env: gym.Env[Any, Any], reference: Reference, config: RecoveryConfig = RecoveryConfig()) -> None:
        from ..sim.controls import DriverControls

        self._controls = DriverControls
        base: Any = env.unwrapped
        self.base = base
        self.ref = reference
        self.config = config
        self.dt = float(base.world.dt_s)
        self.n = max(1, int(round(config.tau_s / self.dt)))

    def _ahead(self, steering: float, pedal: float) -> tuple[float, float, float]:
        """(x, z, speed) of the car after `tau_s` seconds holding these inputs; the car is put back."""
        c = self._controls.pedals(steering, max(pedal, 0.0), max(-pedal, 0.0)).clipped()
        return self.base.world.ego.ahead(self.dt, c, self.n)

    def _bisect(self, f: Any, guess: float, lo: float = -1.0, hi: float = 1.0, f_lo: float | None = None) -> float:
        """The input in [lo, hi] where the increasing outcome `f` crosses zero (the nearer end where it
        does not; `guess` where the input changes nothing, a car standing without its engine)."""
        f_lo = f(lo) if f_lo is None else f_lo
        f_hi = f(hi)
        if f_hi - f_lo < 1e-6:
            return guess
        if f_lo >= 0.0:
            return lo
        if f_hi <= 0.0:
            return hi
        for _ in range(self.config.iterations):
            mid = 0.5 * (lo + hi)
            if f(mid) < 0.0:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def _nearest_root(self, f: Any, guess: float, progress_m: float) -> float:
        """The steering nearest `guess` where `f` (the end's offset across the path, and how far along
        it the end is) crosses zero upwards: held for `tau_s`, a steering far from the log's can turn
        the car round a full circle back onto the path, so the crossings of a grid over [-1, 1] are
        bisected, the nearest kept (where none, the grid's least offset). Only ends at least
        `progress_m` further along the path count: a car that spun or circled back onto the path
        (a keyboard tap's steering as the guess once picked full lock, scrubbing 23 km/h) has not
        rejoined it ahead."""
        grid = np.linspace(-1.0, 1.0, STEERING_GRID)
        ends = np.asarray([f(d) for d in grid])
        values, ahead = ends[:, 0], ends[:, 1] >= progress_m
        if not ahead.any():
            ahead[:] = True  # none goes ahead (a standing car): every end counts
        up = np.flatnonzero((values[:-1] < 0.0) & (values[1:] >= 0.0) & ahead[:-1] & ahead[1:])
        if not up.size:
            return float(grid[ahead][int(np.argmin(np.abs(values[ahead])))]) if np.ptp(values) > 1e-6 else guess
        i = int(up[np.argmin(np.abs(0.5 * (grid[up] + grid[up + 1]) - guess))])
        return self._bisect(lambda d: f(d)[0], guess, float(grid[i]), float(grid[i + 1]), float(values[i]))

    def label(self, hint: int) -> tuple[np.ndarray, int]:
        """The recovery action [steering, pedal] for the car's state now, and the path segment it is at
        (the next call's `hint`). The pedal's target is the log's speed at the place the car reaches,
        not where the log was at that time: labels that also made up time lost against the log
        (ChauffeurNet's labels are poses in time, Bansal et al. 2018) taught clones to speed, since
        nothing in an observation tells how far behind the log a car is (docs/imitation.md)."""
        ref = self.ref
        s = self.base.world.ego.state
        _, _, seg = ref.locate(float(s.x), float(s.z), hint)
        row = ref.rows[min(seg, len(ref.rows) - 1)]
        steering, logged_pedal = float(ref.steering[row]), float(ref.pedal[row])  # the log's inputs there: the first guess

        def speed_error(pedal: float) -> float:
            x, z, u = self._ahead(steering, pedal)
            return u - ref.speed_at(ref.locate(x, z, seg)[0])

        here = ref.locate(float(s.x), float(s.z), seg)[0]

        def across(steer: float) -> tuple[float, float]:  # steering left (+) ends the car further left (+); and how far along
            x, z, _ = self._ahead(steer, pedal)
            along, side, _ = ref.locate(x, z, seg)
            return side, along - here

        pedal = self._bisect(speed_error, logged_pedal)  # with the log's wheel there
        progress = 0.5 * float(s.u) * self.config.tau_s  # half the way the car would go straight on
        steering = self._nearest_root(across, steering, progress)  # with that pedal
        pedal = self._bisect(speed_error, pedal)  # with that steering
        return np.asarray([steering, pedal], dtype=np.float32), seg


def perturbations(n: int, config: RecoveryConfig) -> np.ndarray:
    """n seeded (lateral m, heading rad, speed factor) draws, uniform in the config's ranges."""
    rng = np.random.default_rng(config.seed)
    return np.c_[
        rng.uniform(-config.lateral_m, config.lateral_m, n),
        rng.uniform(-config.heading_rad, config.heading_rad, n),
        rng.uniform(1.0 - config.slower, 1.0 + config.faster, n),
    ]


def perturbed_pose(state: dict[str, float], lateral_m: float, heading_rad: float, speed_factor: float) -> dict[str, Any]:
    """A `start_pose` option: the logged state moved `lateral_m` to its left (+), turned and sped up."""
    yaw = state["yaw"]
    return {
        "x": state["x"] - math.cos(yaw) * lateral_m,
        "y": state["y"],
        "z": state["z"] + math.sin(yaw) * lateral_m,
        "yaw_rad": yaw + heading_rad,
        "speed_mps": max(0.0, state["u"] * speed_factor),
        "engine_on": bool(state["engine_on"] > 0.5),
    }


def recovery_copy(
    env: gym.Env[Any, Any], reference: Reference, t_s: float, world_state: Any, perturbation: np.ndarray, source: str,
    config: RecoveryConfig = RecoveryConfig(), horizon_s: float | None = None, noise: np.random.Generator | None = None,
) -> Episode | None:  # fmt: skip
    """One copy: the logged state at `t_s` perturbed, in the env's world as it was then (`world_state`,
    from `World.get_state()`; None: the world as the env resets it), driven with recovery labels for
    `horizon_s` (default the config's; or until the episode or the log ends); None where there is
    nothing to drive. With `noise` (DART, Laskey et al. 2017: "Disturbances for Augmenting Robot
    Trajectories") the car is driven by each label plus Gaussian noise (SD `dart_steering`,
    `dart_pedal`) while the episode records the label: the states drift as a clone's own errors
    would take it, each labelled with the way back (kind `dart`)."""
    steps = int(round((config.horizon_s if horizon_s is None else horizon_s) * _policy_hz(env)))
    state = reference.at_time(t_s)
    pose = perturbed_pose(state, *map(float, perturbation))
    base: Any = env.unwrapped
    _, info = env.reset(seed=0, options={"start_pose": pose})
    if world_state is not None:  # traffic, lights and triggers as the replay had them at t_s
        base.world.set_state(world_state)
        base.world.ego.reset_to(pose["x"], pose["y"], pose["z"], pose["yaw_rad"], pose["speed_mps"], engine_on=pose["engine_on"])
    base.world.ego.inputs.steering = state["steering"]  # the wheel where the log held it (in the observation)
    kind = "recovery" if noise is None else "dart"
    ep = _start(env, source, kind, None, base.obs_type.observe(), info)  # the reset's info keys (at the copy's start pose)
    ep.start_pose = {k: float(v) for k, v in pose.items()}
    labeler = RecoveryLabeler(env, reference, config)
    hint = reference.locate(pose["x"], pose["z"], int(np.searchsorted(reference.t[reference.rows], t_s)))[2]
    end_s = reference.t[-1] - config.tau_s  # beyond it there is no log to rejoin
    for k in range(steps):
        if t_s + k / _policy_hz(env) > end_s:
            break
        action, hint = labeler.label(hint)
        if noise is None:
            done = _step(env, ep, action)[2]
        else:  # executed with noise, recorded as labelled
            sd = np.asarray([config.dart_steering, config.dart_pedal])
            done = _step(env, ep, np.clip(action + noise.normal(0.0, sd), -1.0, 1.0).astype(np.float32))[2]
            ep.actions[-1] = action
        if done:
            break
    if not ep.actions:
        return None
    if not (ep.terminations[-1] or ep.truncations[-1]):
        ep.truncations[-1] = True
    return ep


def cardata_with_recovery(
    path: str | Path, env_id: str | None, task: str | None, env_kwargs: dict[str, Any] | None = None, trim_idle: bool = False,
    config: RecoveryConfig = RecoveryConfig(),
) -> list[Episode]:  # fmt: skip
    """An OpenDS carData.txt as `episodes.from_cardata` exports it, then its recovery copies."""
    from ..record.conform import Recorded
    from ..record.mcap_walk import MAGIC

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such drive")
    with p.open("rb") as f:
        if f.read(len(MAGIC)) == MAGIC:
            raise UserError(f"{p}: recovery copies are made of OpenDS carData.txt logs, not of MCAP recordings")
    rec = Recorded(p)
    i0 = cardata_start_row(rec, trim_idle)
    env = _input_env(env_id, task, str(p), env_kwargs or {})
    try:
        if not (isinstance(env.action_space, gym.spaces.Box) and env.action_space.shape == (2,)):
            raise UserError(f"{p}: recovery labels are [steering, pedal] actions, the env has {env.action_space}")
        hz = _policy_hz(env)
        every = max(1, int(round(config.every_s * hz)))
        base: Any = env.unwrapped
        snapshots: dict[int, Any] = {}
        steps = cardata_steps(rec, i0, hz)

        def feed() -> Any:
            for k, item in enumerate(steps):
                if k % every == 0:
                    snapshots[k] = base.world.get_state()
                yield item

        demo = drive(env, str(p), "cardata", None, {"start_pose": cardata_start_pose(rec, i0)}, feed())
        ref = Reference.from_cardata(rec, i0)
        out = [demo]
        if not ref.moves:
            return out
        starts = [k for k in range(0, len(steps), every) for _ in range(config.draws)]
        for j, (k, perturbation) in enumerate(zip(starts, perturbations(len(starts), config), strict=True)):
            ep = recovery_copy(env, ref, k / hz, snapshots.get(k), perturbation, f"{p}#recovery{j}", config)
            if ep is not None:
                out.append(ep)
        rng = np.random.default_rng([config.seed, 1])  # the noise: seeded, apart from the perturbations
        for j in range(config.dart):  # from the log's own first state, the whole drive
            ep = recovery_copy(env, ref, 0.0, snapshots.get(0), np.asarray([0.0, 0.0, 1.0]), f"{p}#dart{j}", config, ref.t[-1], rng)
            if ep is not None:
                out.append(ep)
        return out
    finally:
        env.close()
