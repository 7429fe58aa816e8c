"""The Drive Analyzer: driving measures of a recorded drive, with `opends_gym.metrics`.

Why: the numbers a paper reports -- mean deviation from each ideal track (OpenDS's
algorithm, with its completeness status), LCT MDEV, SDLP, steering reversal rate,
headway/TTC and the reaction results by group -- computed the same way for our MCAP
recordings and OpenDS carData.txt files, with every parameter stated next to its value.

The Lane Change Test's normative path (basic model) also becomes an ideal track,
`lct_normative`, so its OpenDS-style mean deviation and deviation plot come for free.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..metrics.deviation import DeviationResult, mean_deviation
from ..metrics.headway import headway_summary, ttc_summary
from ..metrics.lateral import lane_keeping_mask, sdlp
from ..metrics.lct import LctSign, NormativeModel, lct_mdev, normative_path
from ..metrics.reaction import CORRECT, summarize_reactions
from ..metrics.steering import reversal_rate
from ..sim.controls import STEERING_WHEEL_MAX_DEG
from .drive import Drive, load_drive

LCT_TRACK_ID = "lct_normative"
LCT_GRID_M = 2.0


@dataclass(frozen=True)
class AnalyzerParams:
    """Every choice behind a number (reported with the results)."""

    srr_gap_deg: float = 2.0  # steering reversal gap (steering-wheel degrees)
    srr_cutoff_hz: float = 0.6  # low-pass cut-off before reversal counting
    sdlp_exclude_s: float = 2.5  # samples this close to a lane change are not lane keeping
    headway_threshold_s: float = 1.0
    ttc_threshold_s: float = 3.0


@dataclass
class TrackDeviation:
    track_id: str
    road_width_m: float
    ideal: np.ndarray  # (n, 2) x, z
    result: DeviationResult


@dataclass
class Analysis:
    drive: Drive
    params: AnalyzerParams
    summary: dict[str, float] = field(default_factory=dict)
    deviations: list[TrackDeviation] = field(default_factory=list)
    lct: dict[str, float] = field(default_factory=dict)
    lateral: dict[str, float] = field(default_factory=dict)
    steering: dict[str, float] = field(default_factory=dict)
    headway: dict[str, float] = field(default_factory=dict)
    ttc: dict[str, float] = field(default_factory=dict)
    groups: dict[str, dict[str, float]] = field(default_factory=dict)

    def rows(self) -> list[tuple[str, str, Any, str]]:
        """(section, measure, value, unit) -- the metrics table of CSV, JSON, PDF and CLI."""
        out: list[tuple[str, str, Any, str]] = []
        units = {"duration_s": "s", "distance_m": "m", "mean_speed_kmh": "km/h", "max_speed_kmh": "km/h", "fuel_used_l": "l"}
        for k, v in self.summary.items():
            out.append(("drive", k, v, units.get(k, "")))
        for d in self.deviations:
            r = d.result
            out += [
                (f"ideal track {d.track_id}", "mean_deviation_m", r.mean_deviation_m, "m"),
                (f"ideal track {d.track_id}", "status", str(r.status), ""),
                (f"ideal track {d.track_id}", "area_m2", r.area_m2, "m^2"),
                (f"ideal track {d.track_id}", "covered_length_m", r.length_m, "m"),
                (f"ideal track {d.track_id}", "road_width_m", d.road_width_m, "m"),
            ]
        for k, v in self.lct.items():
            out.append(("lane change test", k, v, "m" if k.endswith("_m") else ""))
        for k, v in self.lateral.items():
            out.append(("lateral control", k, v, "m" if k.endswith("_m") else ""))
        for k, v in self.steering.items():
            out.append(
                ("steering", k, v, "1/min" if k.endswith("per_min") else ("deg" if k.endswith("deg") else "Hz" if k.endswith("hz") else ""))
            )
        for k, v in self.headway.items():
            out.append(("headway", k, v, "s" if k.endswith("_s") else ""))
        for k, v in self.ttc.items():
            out.append(("time to collision", k, v, "s" if k.endswith("_s") else "s^2" if k.endswith("s2") else ""))
        for g, stats in self.groups.items():
            for k, v in stats.items():
                out.append((f"reactions {g}", k, v, "s" if k.endswith("_s") else ""))
        return out

    def to_json(self) -> dict[str, Any]:
        d = self.drive
        return {
            "recording": str(d.path),
            "source": d.source,
            "complete": d.complete,
            "notes": list(d.notes),
            "meta": {k: v for k, v in d.meta.items() if k not in ("analysis_lct",)},
            "parameters": asdict(self.params),
            "summary": self.summary,
            "ideal_tracks": {
                t.track_id: {
                    "mean_deviation_m": t.result.mean_deviation_m,
                    "status": str(t.result.status),
                    "area_m2": t.result.area_m2,
                    "covered_length_m": t.result.length_m,
                    "road_width_m": t.road_width_m,
                    **({"problem": t.result.problem} if t.result.problem else {}),
                }
                for t in self.deviations
            },
            "lct": self.lct,
            "lateral": self.lateral,
            "steering": self.steering,
            "headway": self.headway,
            "ttc": self.ttc,
            "reaction_groups": self.groups,
            "reactions": d.reactions,
        }


# ------------------------------------------------------------------ measures
def _uniform(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, float]:
    """Resample to a uniform grid at the median rate (OpenDS rows jitter with the frame rate)."""
    if len(t) < 3:
        return v, math.nan
    dt = float(np.median(np.diff(t)))
    if dt <= 0:
        return v, math.nan
    if np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-9):
        return v, 1.0 / dt
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    return np.interp(grid, t, v), 1.0 / dt


def lct_ideal_track(lct: dict[str, Any], guide: dict[str, Any]) -> np.ndarray:
    """The basic normative LCT path as (x, z) ideal-track points (grid + its corners)."""
    signs = [LctSign(float(d), int(a), int(b)) for d, a, b in lct["signs"]]
    model = NormativeModel(float(lct["start_before_sign_m"]), float(lct["length_per_lane_m"]))
    end = float(lct.get("track_end_m") or (signs[-1].d_m + 200.0 if signs else 200.0))
    d = set(np.arange(LCT_GRID_M, end + 1e-9, LCT_GRID_M).round(6).tolist())  # from the first grid step: t = 0 is not sampled
    for s in signs:
        start = s.d_m - model.start_before_sign_m
        d.update([start, start + model.length_per_lane_m * abs(s.to_lane - s.from_lane)])
    grid = np.asarray(sorted(v for v in d if LCT_GRID_M <= v <= end))
    y = normative_path(grid, signs, lct["lane_laterals_m"], int(lct["initial_lane"]), model)
    sign = float(guide.get("sign", 1.0))
    z0 = float(lct["start_z_m"])
    return np.column_stack([-sign * y, z0 - sign * grid])


def _lct_metrics(drive: Drive, lct: dict[str, Any]) -> dict[str, float]:
    z0 = float(lct["start_z_m"])
    d = z0 - drive.col("z_m")
    y = drive.col("lateral_m")
    signs = [LctSign(float(a), int(b), int(c)) for a, b, c in lct["signs"]]
    passed = [s for s in signs if len(d) and s.d_m <= d[-1]]
    if len(d) < 2 or not passed:
        return {"mdev_basic_m": math.nan, "mdev_adapted_m": math.nan, "signs_passed": float(len(passed))}
    basic = NormativeModel(float(lct["start_before_sign_m"]), float(lct["length_per_lane_m"]))
    out = lct_mdev(d, y, passed, lct["lane_laterals_m"], int(lct["initial_lane"]), basic, float(lct["visibility_m"]))
    out["signs_passed"] = float(len(passed))
    return out


def _group_stats(drive: Drive) -> dict[str, dict[str, float]]:
    rows = [(str(r.get("group", "")), int(r["result"]), float(r["reaction_time_s"])) for r in drive.reactions]
    out: dict[str, dict[str, float]] = {}
    summaries = summarize_reactions(rows)
    everyone = summarize_reactions([("all", r, rt) for _, r, rt in rows]) if len(summaries) > 1 else {}
    for name, s in list(summaries.items()) + list(everyone.items()):
        rts = [rt for g, r, rt in rows if (g == name or name == "all") and r == CORRECT]
        out[name] = {
            "trials": float(s.n),
            "correct": float(s.correct),
            "failures": float(s.failures),
            "misses": float(s.misses),
            "hit_rate": s.hit_rate,
            "mean_rt_s": s.mean_rt_s,
            "sd_rt_s": float(np.std(rts, ddof=1)) if len(rts) > 1 else math.nan,
            "median_rt_s": float(np.median(rts)) if rts else math.nan,
        }
    return out


def track_ids(drive: Drive) -> list[str]:
    ids = list((drive.analysis.get("ideal_tracks") or {}).keys())
    if drive.analysis.get("lct"):
        ids.append(LCT_TRACK_ID)
    return ids


def analyze(
    drive: Drive | str | Path, ideal_track: str | None = None, params: AnalyzerParams | None = None, task: str | Path | None = None
) -> Analysis:
    """All measures of a drive (a `Drive` or a path to an MCAP / carData.txt file)."""
    if not isinstance(drive, Drive):
        drive = load_drive(drive, task=task)
    params = params or AnalyzerParams()
    a = Analysis(drive, params)
    t = drive.col("t_s")
    x, z = drive.col("x_m"), drive.col("z_m")
    speed = drive.col("speed_kmh")
    fuel = drive.col("fuel_used_l")
    finite_fuel = fuel[np.isfinite(fuel)]
    a.summary = {
        "samples": float(drive.n),
        "sample_rate_hz": drive.rate_hz,
        "duration_s": float(t[-1] - t[0]) if drive.n else 0.0,
        "distance_m": float(np.sum(np.hypot(np.diff(x), np.diff(z)))) if drive.n > 1 else 0.0,
        "mean_speed_kmh": float(np.mean(speed)) if drive.n else math.nan,
        "max_speed_kmh": float(np.max(speed)) if drive.n else math.nan,
        "fuel_used_l": float(finite_fuel[-1] - finite_fuel[0]) if len(finite_fuel) else math.nan,
        "collisions": float(sum(1 for e in drive.events if e.get("kind") == "collision")),
    }
    # ideal tracks (OpenDS mean deviation)
    known = track_ids(drive)
    if ideal_track is not None and ideal_track not in known:
        raise ValueError(f"no ideal track '{ideal_track}' in {drive.path}; known: {', '.join(known) or 'none'}")
    path = np.column_stack([x, z])
    for tid, spec in (drive.analysis.get("ideal_tracks") or {}).items():
        if ideal_track in (None, tid):
            ideal = np.asarray(spec["points"], dtype=float)
            width = float(spec.get("road_width_m", 15.0))
            a.deviations.append(TrackDeviation(tid, width, ideal, mean_deviation(path, ideal, width)))
    lct = drive.analysis.get("lct")
    if lct:
        a.lct = _lct_metrics(drive, lct)
        if ideal_track in (None, LCT_TRACK_ID):
            ideal = lct_ideal_track(lct, drive.analysis.get("guide") or {})
            a.deviations.append(TrackDeviation(LCT_TRACK_ID, 15.0, ideal, mean_deviation(path, ideal, 15.0)))
    # lateral control
    keep = lane_keeping_mask(t, drive.col("lane_index"), params.sdlp_exclude_s)
    a.lateral = {
        "sdlp_m": sdlp(drive.col("lane_offset_m"), keep),
        "lane_keeping_fraction": float(np.mean(keep)) if drive.n else math.nan,
        "mean_abs_lane_offset_m": float(np.mean(np.abs(drive.col("lane_offset_m")))) if drive.n else math.nan,
    }
    steer, fs = _uniform(t, drive.col("steering") * STEERING_WHEEL_MAX_DEG)
    a.steering = {
        "reversal_rate_per_min": reversal_rate(steer, fs, params.srr_gap_deg, params.srr_cutoff_hz)
        if len(steer) > 12 and math.isfinite(fs)
        else math.nan,
        "gap_deg": params.srr_gap_deg,
        "cutoff_hz": params.srr_cutoff_hz,
    }
    h = headway_summary(drive.col("headway_s"), params.headway_threshold_s)
    a.headway = {
        "mean_s": h["mean_s"],
        "min_s": h["min_s"],
        "fraction_below_threshold": h["fraction_below"],
        "threshold_s": params.headway_threshold_s,
    }
    dt = 1.0 / drive.rate_hz if math.isfinite(drive.rate_hz) else 0.0
    c = ttc_summary(drive.col("ttc_s"), dt, params.ttc_threshold_s)
    a.ttc = {
        "min_s": c["min_s"],
        "time_exposed_s": c["time_exposed_s"],
        "time_integrated_s2": c["time_integrated_s2"],
        "threshold_s": params.ttc_threshold_s,
    }
    a.groups = _group_stats(drive)
    return a


# ------------------------------------------------------------------ exports
def _cell(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def write_csv(a: Analysis, out: str | Path) -> list[Path]:
    """`out` gets the per-sample table; `<stem>_metrics.csv` the measures, `<stem>_reactions.csv` the trials."""
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    cols = a.drive.columns
    names = list(cols)
    with open(p, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for i in range(a.drive.n):
            w.writerow([_cell(float(cols[n][i])) for n in names])
    written = [p]
    mp = p.with_name(f"{p.stem}_metrics.csv")
    with open(mp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["section", "measure", "value", "unit"])
        for row in a.rows():
            w.writerow([row[0], row[1], _cell(row[2]), row[3]])
    written.append(mp)
    if a.drive.reactions:
        rp = p.with_name(f"{p.stem}_reactions.csv")
        keys = ["timer_id", "kind", "group", "result", "reaction_time_s", "start_t_s", "t_s", "experiment_time_s", "comment"]
        with open(rp, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(keys)
            for r in a.drive.reactions:
                w.writerow([_cell(r.get(k, "")) for k in keys])
        written.append(rp)
    return written


def analysis_json(a: Analysis) -> str:
    def clean(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v

    return json.dumps(clean(a.to_json()), indent=1, default=str)
