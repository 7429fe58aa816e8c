"""Simulate the virtual population on the calibration tasks and compare with the literature.

Why: the population is only useful if its attentive drivers and its load effects fall where
people's do. `literature()` reads the published values (`literature.csv`, one row per
metric, task and condition, with its source); `measure(...)` drives a population through
one calibration task and returns one value per participant; `compare(...)` sets the model
against the row. tests/test_calibration.py and docs/gen_calibration.py use these.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib import resources
from typing import Any

import gymnasium as gym
import numpy as np

from .episodes import run_episode
from .participant import ParticipantDriver
from .population import ParticipantParams


@dataclass(frozen=True)
class LiteratureRow:
    """One published value: mean (or NaN) and the range a model must fall in for the mean,
    the between-participant SD and, for a load effect, the raw difference and Cohen's d."""

    key: str
    metric: str
    task: str
    condition: str
    low: float
    high: float
    sd_low: float
    sd_high: float
    d_low: float
    d_high: float
    published: str  # the values as published
    source: str
    verified: str  # "yes (...)" (checked against the paper or its abstract) or "unverified"
    asserted: str  # "yes", or "no: why" (a known gap, shown in docs/calibration.md)


def literature() -> dict[str, LiteratureRow]:
    """The rows of the package's `literature.csv`, by key."""
    text = resources.files("opends_gym.drivers").joinpath("literature.csv").read_text(encoding="utf-8")
    rows: dict[str, LiteratureRow] = {}
    for line, rec in enumerate(csv.DictReader(text.splitlines()), start=2):
        try:
            nums = {k: float(rec[k]) if rec[k] else math.nan for k in ("low", "high", "sd_low", "sd_high", "d_low", "d_high")}
        except ValueError as e:
            raise ValueError(f"literature.csv line {line}: {e}") from None
        rows[rec["key"]] = LiteratureRow(
            rec["key"],
            rec["metric"],
            rec["task"],
            rec["condition"],
            published=rec["published"],
            source=rec["source"],
            verified=rec["verified"],
            asserted=rec["asserted"],
            **nums,
        )
    return rows


# ---------------------------------------------------------------------------- tasks
def _lct(signs: int, visibility_m: float = 40.0, modality: str = "tactile") -> gym.Env[Any, Any]:
    """The LCT with a DRT of the given ISO 17488 modality (the participant reads it from the
    wrapper), scored as ISO 26022 scores it (`iso_mdev_m`: the lead-in and lead-out, pure lane
    keeping, are not scored, so a short calibration track reads like the full one)."""
    from ..envs.drt import DetectionResponseTask

    env = gym.make("OpenDS/LaneChangeTest-v0", action="continuous_buttons", signs=signs, visibility_m=visibility_m, scoring="iso26022")
    return DetectionResponseTask(env, modality=modality)


def _brake(stimuli: int) -> gym.Env[Any, Any]:
    return gym.make("OpenDS/BrakeReaction-v0", stimuli=stimuli)


def _platoon(length_m: float) -> gym.Env[Any, Any]:
    # one stimulus, at the end: the drive before it is pure car following and lane keeping
    return gym.make("OpenDS/ThreeVehiclePlatoon-v0", stimuli=1, lead_in_m=length_m, lead_out_m=100.0)


def _headway(env: gym.Env[Any, Any]) -> float:
    """Mean time headway (front to front) once following has settled (after 20 s). The
    platoon runs free car following (`keep_band=False`): the lead adapts its speed only
    outside 20-50 m."""
    tr = env.unwrapped.trace  # type: ignore[attr-defined]
    t, h, v = tr.col("t_s"), tr.col("headway_s"), tr.col("speed_mps")
    ok = (t > 20.0) & np.isfinite(h) & (v > 5.0)
    return float(np.mean(h[ok])) if ok.any() else math.nan


def lane_change_durations(env: gym.Env[Any, Any], smooth_s: float = 1.0, still_mps: float = 0.15) -> list[float]:
    """Durations of the lane changes of the episode, from the start to the end of the lateral
    movement (Toledo & Zohar 2007's definition): around each crossing of a lane line, the
    span over which the lateral speed (averaged over `smooth_s`) exceeds `still_mps`."""
    base: Any = env.unwrapped
    tr = base.trace
    t, y = tr.col("t_s"), tr.col("lateral_m")
    if len(t) < 3:
        return []
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(smooth_s / dt)))
    v = np.convolve(np.gradient(y, t), np.ones(k) / k, mode="same")
    lanes = sorted(base.lane_laterals)
    lines = [(a + b) / 2.0 for a, b in itertools.pairwise(lanes)]
    out, last_end = [], -1
    for i in range(1, len(y)):
        if not any((y[i - 1] - m) * (y[i] - m) < 0 for m in lines) or i <= last_end:
            continue
        sign = math.copysign(1.0, y[i] - y[i - 1])
        j0 = i
        while j0 > 0 and sign * v[j0] > still_mps:
            j0 -= 1
        j1 = i
        while j1 < len(y) - 1 and sign * v[j1] > still_mps:
            j1 += 1
        crossings = sum(1 for m in lines if (y[j0] - m) * (y[j1] - m) < 0)
        if crossings == 1 and j1 < len(y) - 1 and j0 > 0:
            out.append(float(t[j1] - t[j0]))
        last_end = j1
    return out


Run = Callable[[Sequence[ParticipantParams], str, int], list[dict[str, float]]]


Reader = Callable[[gym.Env[Any, Any], dict[str, Any], ParticipantDriver], dict[str, float]]


def _runner(make: Callable[[], gym.Env[Any, Any]], read: Reader, **driver: Any) -> Run:
    def run(population: Sequence[ParticipantParams], load: str, seed: int) -> list[dict[str, float]]:
        env = make()
        out = []
        for p in population:
            # common random numbers: each load's drive meets the same noise, so the measured
            # effect is the mechanism's (same expectation as independent drives, less variance)
            agent = ParticipantDriver(None, p, load, common_noise=True, **driver)
            ep = run_episode(env, agent, seed + p.id)
            out.append(read(env, ep.metrics, agent))
        env.close()
        return out

    return run


def _lct_read(env: gym.Env[Any, Any], m: dict[str, Any], agent: ParticipantDriver) -> dict[str, float]:
    keys = ("mdev_basic_m", "iso_mdev_m", "iso_mean_latency_s", "drt_mean_rt_s", "drt_hit_rate")
    out = {k: float(m[k]) for k in keys}
    glances = [b - a for a, b in agent.glances]
    out["glance_s"] = float(np.mean(glances)) if glances else math.nan
    return out


# literature row -> (run of `runs`, measure, loaded condition or None for a level): the rows
# the tests and docs/gen_calibration.py compare one measure of one run for
RUN_CHECKS: dict[str, tuple[str, str, str | None]] = {
    "drt_rt_baseline": ("lct", "drt_mean_rt_s", None),
    "drt_hit_baseline": ("lct", "drt_hit_rate", None),
    "drt_rt_cognitive": ("lct", "drt_mean_rt_s", "cognitive"),
    "drt_hit_cognitive": ("lct", "drt_hit_rate", "cognitive"),
    "drt_rt_tactile_visual_manual": ("lct", "drt_mean_rt_s", "visual_manual"),
    "drt_hit_visual_visual_manual": ("lct_visual_drt", "drt_hit_rate", "visual_manual"),
    "brake_rt_expected": ("brake_expected", "brake_rt_s", None),
    "brake_rt_unexpected": ("brake_unexpected", "brake_rt_s", None),
    "brake_rt_cognitive": ("brake_expected", "brake_rt_s", "cognitive"),
    "sdlp_baseline": ("platoon", "sdlp_m", None),
    "sdlp_visual_manual": ("platoon", "sdlp_m", "visual_manual"),
    "sdlp_cognitive": ("platoon", "sdlp_m", "cognitive"),
    "mdev_baseline": ("lct", "iso_mdev_m", None),
    "mdev_visual_manual": ("lct", "iso_mdev_m", "visual_manual"),
    "mdev_cognitive": ("lct", "iso_mdev_m", "cognitive"),
    "time_headway": ("platoon", "time_headway_s", None),
    "lane_change_duration": ("lane_change", "lane_change_s", None),
}


def runs(short: bool = False) -> dict[str, Run]:
    """Calibration runs by name, each giving per participant a dict of measures; `short`
    runs shorter tasks (for the tests)."""
    signs = 4 if short else 18
    brake_n = 3 if short else 9
    platoon_m = 1500.0 if short else 3000.0

    def brake_rt(e: gym.Env[Any, Any], m: dict[str, Any], a: ParticipantDriver) -> dict[str, float]:
        return {"brake_rt_s": float(m["brake_onset_s"])}

    def lane_keeping(e: gym.Env[Any, Any], m: dict[str, Any], a: ParticipantDriver) -> dict[str, float]:
        return {"sdlp_m": float(m["sdlp_m"]), "time_headway_s": _headway(e)}

    def lane_change(e: gym.Env[Any, Any], m: dict[str, Any], a: ParticipantDriver) -> dict[str, float]:
        return {"lane_change_s": float(np.mean(lane_change_durations(e) or [math.nan]))}

    return {
        "lct": _runner(lambda: _lct(signs), _lct_read),
        "lct_visual_drt": _runner(lambda: _lct(signs, modality="visual"), _lct_read),
        "brake_expected": _runner(lambda: _brake(brake_n), brake_rt),
        "brake_unexpected": _runner(lambda: _brake(brake_n), brake_rt, instructed=False),
        "platoon": _runner(lambda: _platoon(platoon_m), lane_keeping, keep_band=False),
        "lane_change": _runner(lambda: _lct(signs, visibility_m=250.0), lane_change),
    }


# ---------------------------------------------------------------------------- statistics
def cohens_d(a: Sequence[float], b: Sequence[float]) -> float:
    """(mean b - mean a) / pooled SD (Cohen 1988's d for two conditions)."""
    x, y = np.asarray(a, float), np.asarray(b, float)
    x, y = x[np.isfinite(x)], y[np.isfinite(y)]
    if len(x) < 2 or len(y) < 2:
        return math.nan
    pooled = math.sqrt(((len(x) - 1) * x.var(ddof=1) + (len(y) - 1) * y.var(ddof=1)) / (len(x) + len(y) - 2))
    return float((y.mean() - x.mean()) / pooled) if pooled > 0 else math.nan


@dataclass(frozen=True)
class Comparison:
    row: LiteratureRow
    value: float  # model mean (or raw difference for an effect)
    sd: float  # model between-participant SD (NaN for an effect)
    d: float  # Cohen's d for an effect (NaN otherwise)

    @property
    def ok(self) -> bool:
        r = self.row
        inside = r.low <= self.value <= r.high
        if math.isfinite(r.sd_low) and not r.sd_low <= self.sd <= r.sd_high:
            return False
        if math.isfinite(r.d_low) and not r.d_low <= self.d <= r.d_high:
            return False
        return inside


def level(row: LiteratureRow, values: Sequence[float]) -> Comparison:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return Comparison(row, float(v.mean()) if len(v) else math.nan, float(v.std(ddof=1)) if len(v) > 1 else math.nan, math.nan)


def effect(row: LiteratureRow, baseline: Sequence[float], loaded: Sequence[float]) -> Comparison:
    a, b = np.asarray(baseline, float), np.asarray(loaded, float)
    ok = np.isfinite(a) & np.isfinite(b)
    diff = float(np.mean(b[ok] - a[ok])) if ok.any() else math.nan
    return Comparison(row, diff, math.nan, cohens_d(a[ok], b[ok]))
