"""Open-loop replay of a real OpenDS drive log through our vehicle model (`opends-gym conform`).

Why: the vehicle model must drive like OpenDS's. A `carData.txt` holds what a driver did
(steering, gas, brake at their timestamps) and what OpenDS's car did (pose, speed); feeding
the inputs to our car from the recorded state and comparing the states shows how close the
two models are, on any task's drives, without OpenDS.

Two replays, both on the task's own car parameters (never tuned per log):
* multiple shooting: restart from the recorded state (pose and speed) every `window_s`
  seconds, at the first sample from there on whose state the log holds completely (steering
  centred on it and the sample before: no yaw rate or slip under way), and compare at the
  next window's start, so that an early difference does not accumulate; the medians over
  windows are the figures;
* one open loop over the whole run, compared at every sample (RMS speed error), written as a
  trace for plots and rechecks.
Inputs are held from their sample to the next (the log has no finer timing); the physics
runs at OpenDS's Bullet step, 0.01 s, in simulated time: OpenDS stamps rows with wall-clock
time, and where its physics fell behind the clock (a slow machine) the log's own distances
and speeds give the rate (`time_scale`). Speeds compared are |velocity|, as OpenDS logs them.
Where the task's ground is unknown (its `.j3o` models and no readable terrain height map),
the ground is the recorded height profile and the result says so (`ground`, and how each
backend uses it, `ground_model`: `fast` follows the recorded heights and the recorded path's
grade, which pulls the car and pitches its chassis for the powertrain's grade load; `bullet`
takes a plane at the first sample's height, so a log with much relief, `ground_relief_m`, is
compared on flat ground there); the scene's other models
are left out (their shapes are unknown, and open-loop drift must not hit stand-in boxes).
"""

from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..sim.controls import DriverControls
from ..sim.ego.car import EgoCar, make_backend
from ..task import DrivingTask, load_task
from ..task.model_scene import Terrain
from .cardata import read_cardata
from .messages import yaw_from_jme_quaternion

PHYSICS_DT_S = 0.01  # OpenDS's Bullet step (Simulator: setAccuracy(0.01f))
WINDOW_S = 5.0
MIN_DURATION_S = 20.0  # the goals apply to drives at least this long
# below this the car stands: even a full-lock wheel (1 rad, sim.ego.spec.MAX_WHEEL_ANGLE_RAD) gives
# a lateral acceleration of v^2 tan(1) / 2.7 m wheelbase = 0.04 m/s^2 at 1 km/h, no tyre slip
STANDING_KMH = 1.0
GOALS = {"median_speed_err_kmh": 2.0, "median_heading_err_deg": 3.0, "median_pos_err_m": 1.5, "rms_speed_err_kmh": 5.0}
TRACE_COLUMNS = ("t_s", "x_m", "z_m", "yaw_rad", "speed_kmh")
GROUND_MODELS = {"fast": "height and path grade of the nearest recorded sample", "bullet": "plane at the first recorded height"}


class Recorded:
    """A drive log's columns as the replay needs them (heading unwrapped, seconds from the first row)."""

    def __init__(self, path: str | Path) -> None:
        cd = read_cardata(path)
        if cd.n < 2:
            raise ValueError(f"{path}: a drive log needs at least 2 rows, it has {cd.n}")
        c = cd.columns
        self.path = Path(path)
        self.t = cd.t_s()
        if np.any(np.diff(self.t) < 0.0):
            bad = int(np.argmax(np.diff(self.t) < 0.0)) + 1
            raise ValueError(f"{path}: row {bad + 1} goes back in time (epoch_ms {int(c['epoch_ms'][bad])})")
        self.x, self.y, self.z = c["x_m"], c["y_m"], c["z_m"]
        self.yaw = np.unwrap([yaw_from_jme_quaternion(*q) for q in zip(c["qx"], c["qy"], c["qz"], c["qw"])])
        self.speed_kmh = c["speed_kmh"]
        self.steering = c["steering"]
        self.brake = c["brake"]
        self.engine_on = c["engine_on"]
        self.n = cd.n
        self.time_scale = self._time_scale()
        self.sim_t = self.t * self.time_scale
        self.gas = np.abs(c["gas"]) * self._gas_direction(np.abs(c["gas"]))

    def _gas_direction(self, gas: np.ndarray) -> np.ndarray:
        """+1 for the accelerator key, -1 for OpenDS's "accelerate back" key, per row.

        OpenDS logs |gas|, so the key is told by what it did: a run of gas rows is the back
        key when the car moved backwards over it, or when its speed fell on the rows without
        steering or brake (the accelerator never slows a car on flat ground; steering does).
        """
        sign = np.ones(self.n)
        i = 0
        while i < self.n:
            if gas[i] <= 0.0:
                i += 1
                continue
            j = i
            while j < self.n and gas[j] > 0.0:
                j += 1
            end = min(j, self.n - 1)
            dx, dz = self.x[end] - self.x[i], self.z[end] - self.z[i]
            forward = -math.sin(self.yaw[i]) * dx - math.cos(self.yaw[i]) * dz
            quiet = [k for k in range(i, end) if self.steering[k] == 0.0 and self.steering[k + 1] == 0.0 and self.brake[k] == 0.0]
            dv = sum(float(self.speed_kmh[k + 1] - self.speed_kmh[k]) for k in quiet)
            if forward < -0.05 or (quiet and dv < 0.0 and self.speed_kmh[i] > 0.5):
                sign[i:j] = -1.0
            i = j
        return sign

    def _time_scale(self) -> float:
        """Simulated seconds per logged (wall-clock) second.

        OpenDS stamps rows with wall-clock time, but its physics advances at most a few
        0.01 s steps per frame, so on a slow machine simulated time runs behind. The logged
        speed is the simulated one: where the car moves (above 1 m/s), distance over logged
        speed x logged time gives the rate; the median over the log is taken (1 when the car
        hardly moves).
        """
        ds = np.hypot(np.diff(self.x), np.diff(self.z))
        dt = np.diff(self.t)
        v = 0.5 * (self.speed_kmh[1:] + self.speed_kmh[:-1]) / 3.6
        moving = (v > 1.0) & (dt > 0.0)
        if moving.sum() < 5:
            return 1.0
        return float(np.median(ds[moving] / (v[moving] * dt[moving])))

    def settled_row(self, i: int) -> int:
        """The first row from i on whose state the log holds completely: steering centred there
        and on the row before, or the car standing, so that no yaw rate or sideways slip (which
        the log lacks, and which die out within ~0.1 s in OpenDS's car) is under way. A wheel
        (not a keyboard) is seldom exactly centred, but a drive that sets off from rest is
        settled at its first row whatever the wheel does there."""
        while i < self.n - 1 and not (self.speed_kmh[i] < STANDING_KMH or self._centred(i)):
            i += 1
        return i

    def _centred(self, i: int) -> bool:
        return bool(self.steering[i] == 0.0 and (i == 0 or self.steering[i - 1] == 0.0))

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])


def ground_source(task: DrivingTask) -> str:
    """'task terrain' when the scene has a terrain whose height map exists, else 'recorded height profile'."""
    from ..task.missing_assets import find_asset

    for g in task.scene.geometries:
        if isinstance(g, Terrain) and find_asset(task.folder, g.height_map_key) is not None:
            return "task terrain"
    return "recorded height profile"


def _replay_task(task: DrivingTask) -> DrivingTask:
    """The task with only its driver's car model in the scene (see the module docstring)."""
    scene = replace(task.scene, models=(task.car_model,), geometries=())
    return replace(task, scene=scene)


class _Profile:
    """The ground as the drive recorded it: under (x, z) the height of the nearest recorded
    sample, and ahead of a heading the recorded path's grade there (looked up in 5 m cells,
    so a long log costs no more per step than a short one)."""

    CELL_M = 5.0
    GRADE_SPAN_M = 2.5  # the path's grade at a sample: its height change over this far either side

    def __init__(self, rec: Recorded) -> None:
        self._xz = np.column_stack([rec.x, rec.z])
        self._y = np.asarray(rec.y, float)
        cells: dict[tuple[int, int], list[int]] = {}
        for i, (x, z) in enumerate(self._xz):
            cells.setdefault((int(x // self.CELL_M), int(z // self.CELL_M)), []).append(i)
        self._cells = {k: np.asarray(v) for k, v in cells.items()}
        # per sample: the path's grade (rise over horizontal run) and its direction in (x, z)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(rec.x), np.diff(rec.z)))])
        j0 = np.clip(np.searchsorted(s, s - self.GRADE_SPAN_M, side="left"), 0, rec.n - 1)
        j1 = np.clip(np.searchsorted(s, s + self.GRADE_SPAN_M, side="right") - 1, 0, rec.n - 1)
        run = s[j1] - s[j0]
        moved = run > 0.5
        self._grade = np.where(moved, (self._y[j1] - self._y[j0]) / np.where(moved, run, 1.0), 0.0)
        dx, dz = rec.x[j1] - rec.x[j0], rec.z[j1] - rec.z[j0]
        norm = np.where(moved, np.hypot(dx, dz), 1.0)
        self._dir = np.column_stack([dx / norm, dz / norm])

    def _nearest(self, x: float, z: float) -> int:
        cx, cz = int(x // self.CELL_M), int(z // self.CELL_M)
        near = [self._cells[k] for k in ((cx + i, cz + j) for i in (-1, 0, 1) for j in (-1, 0, 1)) if k in self._cells]
        idx = np.concatenate(near) if near else np.arange(len(self._y))
        d = (self._xz[idx, 0] - x) ** 2 + (self._xz[idx, 1] - z) ** 2
        return int(idx[int(np.argmin(d))])

    def __call__(self, x: float, z: float) -> float:
        return float(self._y[self._nearest(x, z)])

    def pitch(self, x: float, z: float, yaw: float) -> float:
        """The road's slope (rad, positive uphill) for a car at (x, z) heading `yaw`: the
        recorded path's grade, along the part of it the heading follows."""
        i = self._nearest(x, z)
        along = -math.sin(yaw) * self._dir[i, 0] - math.cos(yaw) * self._dir[i, 1]
        return math.atan(float(self._grade[i]) * along)


class _Replay:
    """Our car on the log's task, restartable from any recorded row."""

    def __init__(self, task: DrivingTask, rec: Recorded, physics: str, ground: str) -> None:
        self.rec = rec
        replay_task = _replay_task(task) if ground != "task terrain" else task
        options: dict[str, Any] = {}
        if ground != "task terrain":
            # fast: the height at the nearest recorded sample; bullet: a plane at the first sample's height
            if physics == "fast":
                profile = _Profile(rec)
                options["ground_height"], options["ground_pitch"] = profile, profile.pitch
            else:
                options["ground_height"] = float(rec.y[0])
        self.backend = make_backend(physics, replay_task, **options)
        self.car = EgoCar(replay_task, self.backend)

    def restart(self, i: int) -> None:
        """Put the car at recorded row i: pose, speed, the automatic's gear and its rpm."""
        r = self.rec
        v = float(r.speed_kmh[i]) / 3.6
        self.car.reset_to(float(r.x[i]), float(r.y[i]), float(r.z[i]), float(r.yaw[i]), v, engine_on=bool(r.engine_on[i]))

    def run(self, i0: int, i1: int) -> np.ndarray:
        """Step from row i0's time to row i1's with the recorded inputs; the states (t, x, z, yaw, speed km/h) per step."""
        r = self.rec
        t, t_end = float(r.sim_t[i0]), float(r.sim_t[i1])
        car = self.car
        s = car.state
        out = [(t, s.x, s.z, s.yaw, s.speed_mps * 3.6)]
        k = i0
        engine = bool(r.engine_on[i0])
        while t < t_end - 1e-9:
            while k + 1 <= i1 and r.sim_t[k + 1] <= t + 1e-9:
                k += 1
            on = bool(r.engine_on[k])
            c = DriverControls(
                steering=float(r.steering[k]), accelerator=float(r.gas[k]), brake=float(r.brake[k]), engine_on=on if on != engine else None
            )
            engine = on
            car.step(PHYSICS_DT_S, c)
            t += PHYSICS_DT_S
            out.append((t, s.x, s.z, s.yaw, s.speed_mps * 3.6))
        return np.asarray(out)

    def close(self) -> None:
        self.backend.close()


def _at(states: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Simulated (x, z, yaw, speed) at times t, linearly between physics steps."""
    ts = states[:, 0]
    return np.array([np.interp(t, ts, states[:, j]) for j in range(1, 5)])


def conform(
    log: str | Path,
    task: str | Path | DrivingTask,
    physics: str = "fast",
    window_s: float = WINDOW_S,
    trace: str | Path | None = None,
) -> dict[str, Any]:
    """Replay `log` on `task` with `physics` ('fast' or 'bullet'); the figures and the goals' verdict.

    See the module docstring. `trace`: a CSV of the whole-run open loop at the log's timestamps.
    """
    rec = Recorded(log)
    the_task = task if isinstance(task, DrivingTask) else load_task(task)
    ground = ground_source(the_task)
    sim = _Replay(the_task, rec, physics, ground)
    try:
        # multiple shooting: one window per window_s seconds, from its first row to the next window's first row
        starts = [rec.settled_row(int(np.searchsorted(rec.t, k * window_s - 1e-9))) for k in range(int(rec.duration_s // window_s) + 1)]
        starts = sorted({i for i in starts if i < rec.n - 1})
        bounds = [(a, b) for a, b in zip(starts, starts[1:] + [rec.n - 1]) if rec.t[b] - rec.t[a] >= 0.5 * window_s]
        speed_err, heading_err, pos_err = [], [], []
        for a, b in bounds:
            sim.restart(a)
            x, z, yaw, v = _at(sim.run(a, b), float(rec.sim_t[b]))
            speed_err.append(abs(v - rec.speed_kmh[b]))
            heading_err.append(abs(math.degrees(math.remainder(yaw - rec.yaw[b], 2.0 * math.pi))))
            pos_err.append(math.hypot(x - rec.x[b], z - rec.z[b]))
        # the whole run, open loop
        sim.restart(0)
        whole = _at(sim.run(0, rec.n - 1), rec.sim_t)
    finally:
        sim.close()
    err = whole[3] - rec.speed_kmh
    result: dict[str, Any] = {
        "log": str(log),
        "task": the_task.name,
        "physics": physics,
        "ground": ground,
        "ground_model": GROUND_MODELS[physics] if ground != "task terrain" else "task terrain",
        "ground_relief_m": round(float(np.max(rec.y) - np.min(rec.y)), 3),
        "duration_s": round(rec.duration_s, 3),
        "time_scale": round(rec.time_scale, 4),
        "samples": rec.n,
        "window_s": window_s,
        "windows": len(bounds),
        "median_speed_err_kmh": _median(speed_err),
        "median_heading_err_deg": _median(heading_err),
        "median_pos_err_m": _median(pos_err),
        "rms_speed_err_kmh": round(float(np.sqrt(np.mean(err * err))), 3),
        "final_pos_err_m": round(float(math.hypot(whole[0][-1] - rec.x[-1], whole[1][-1] - rec.z[-1])), 3),
        "goals": dict(GOALS),
    }
    checked = rec.duration_s >= MIN_DURATION_S
    result["goals_apply"] = checked
    result["passed"] = all(result[k] <= g for k, g in GOALS.items()) if checked else None
    if trace is not None:
        write_trace(trace, rec.t, whole)
    return result


def _median(values: list[float]) -> float:
    return round(float(np.median(values)), 3) if values else math.nan


def write_trace(path: str | Path, t: np.ndarray, states: np.ndarray) -> None:
    """The whole-run open loop at the log's timestamps: t_s, x_m, z_m, yaw_rad, speed_kmh."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRACE_COLUMNS)
        for i in range(len(t)):
            w.writerow([f"{t[i]:.3f}", f"{states[0][i]:.4f}", f"{states[1][i]:.4f}", f"{states[2][i]:.6f}", f"{states[3][i]:.4f}"])
