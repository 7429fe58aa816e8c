"""`Drive`: one table for a drive however it was recorded (our MCAP or OpenDS carData.txt).

Why: the analyzer, the report and the OpenDS export should not care where a drive came
from. `load_drive` turns either source into per-sample columns (SI units, names as in
`/ego`), the event list, the scored reaction trials and the road facts (lanes, ideal
tracks, reaction-group colours, LCT geometry) the metrics need.

For carData.txt the road facts come from the task (`task=` or the file's `Driving Task:`
line, resolved against the file's folder and its parents), and the trials and events from
`reactionData.xml` / `drivingTaskLog.txt` beside it when present.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..sim.road import Polyline
from .cardata import CarData, read_cardata
from .mcap_io import read_recording
from .mcap_walk import MAGIC, not_mcap_reason
from .messages import yaw_from_jme_quaternion
from .opends_logs import read_driving_task_log, read_reaction_data
from .reference import log_reference
from .schemas import EGO, EVENTS, REACTIONS

log = logging.getLogger(__name__)

COLUMNS = (
    "t_s",
    "x_m",
    "y_m",
    "z_m",
    "yaw_rad",
    "qx",
    "qy",
    "qz",
    "qw",
    "speed_kmh",
    "steering",
    "accelerator",
    "brake",
    "engine_on",
    "gear",
    "rpm",
    "fuel_used_l",
    "lane_index",
    "s_m",
    "lateral_m",
    "lane_offset_m",
    "lead_gap_m",
    "headway_s",
    "ttc_s",
)
_INF_WHEN_NULL = ("lead_gap_m", "headway_s", "ttc_s")


@dataclass
class Drive:
    source: str  # mcap | cardata
    path: Path
    columns: dict[str, np.ndarray]
    events: list[dict[str, Any]] = field(default_factory=list)
    reactions: list[dict[str, Any]] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)  # task_name, driver, created_utc, env_id, seed, ...
    analysis: dict[str, Any] = field(default_factory=dict)  # lanes, ideal_tracks, reaction_groups, guide, lct
    complete: bool = True
    start_epoch_ms: int = 0  # wall-clock of t = 0 (for OpenDS exports)
    notes: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.columns["t_s"])

    def col(self, name: str) -> np.ndarray:
        return self.columns[name]

    @property
    def rate_hz(self) -> float:
        t = self.columns["t_s"]
        return float(1.0 / np.median(np.diff(t))) if len(t) > 2 else math.nan


def load_drive(path: str | Path, task: str | Path | None = None) -> Drive:
    """A drive from an MCAP recording or an OpenDS carData.txt (decided by content)."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such recording")
    with open(p, "rb") as f:
        magic = f.read(8)
    if magic == MAGIC:
        return _from_mcap(p)
    if p.suffix.lower() == ".mcap":  # not the carData parser's business: say what is wrong
        raise ValueError(f"{p}: not an MCAP recording ({not_mcap_reason(magic)})")
    return _from_cardata(p, task)


# ------------------------------------------------------------------ MCAP
def _from_mcap(p: Path) -> Drive:
    rec = read_recording(p, topics=(EGO, EVENTS, REACTIONS))
    ego = rec.topic(EGO)
    cols: dict[str, np.ndarray] = {}
    for name in COLUMNS:
        fill = math.inf if name in _INF_WHEN_NULL else math.nan
        cols[name] = np.asarray([_num(m.get(name), fill) for m in ego], dtype=float)
    meta = dict(rec.meta)
    analysis = dict(meta.pop("analysis", None) or {})
    if meta.get("analysis_lct"):
        analysis["lct"] = meta["analysis_lct"]
    drive = Drive("mcap", p, cols, rec.topic(EVENTS), rec.topic(REACTIONS), meta, analysis, rec.complete)
    drive.start_epoch_ms = _epoch_ms(str(meta.get("created_utc", "")))
    if not ego:
        raise ValueError(f"{p}: the recording holds no /ego samples")
    if not rec.complete:
        why = rec.problem or "it ends at the last flush"
        drive.notes.append(f"the recording was cut short (no footer; {why}); analysed up to t = {cols['t_s'][-1]:.2f} s")
    return drive


def _num(v: Any, fill: float) -> float:
    if v is None:
        return fill
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    try:
        return float(v)
    except (TypeError, ValueError):
        return fill


def _epoch_ms(iso: str) -> int:
    import datetime as _dt

    try:
        d = _dt.datetime.strptime(iso, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=_dt.timezone.utc)
    except ValueError:
        return 0
    return int(round(d.timestamp() * 1000))


# ------------------------------------------------------------------ carData.txt
def _resolve_task(p: Path, cd: CarData, task: str | Path | None) -> Any:
    from ..task import load_task

    if task is not None:
        return load_task(task)
    if not cd.driving_task:
        return None
    rel = Path(cd.driving_task)
    for base in [p.parent, *p.parent.parents, Path.cwd()]:
        cand = base / rel
        if cand.exists():
            try:
                return load_task(cand)
            except Exception as e:  # a broken task must not stop the analysis of the drive itself
                log.warning("%s: could not load the driving task %s: %s", p, cand, e)
                return None
    return None


def _from_cardata(p: Path, task: str | Path | None) -> Drive:
    cd = read_cardata(p)
    if cd.n == 0:
        raise ValueError(f"{p}: carData file without rows")
    c = cd.columns
    n = cd.n
    t = cd.t_s()
    yaw = np.asarray([yaw_from_jme_quaternion(*q) for q in zip(c["qx"], c["qy"], c["qz"], c["qw"])])
    nan = np.full(n, math.nan)
    inf = np.full(n, math.inf)
    cols = {
        "t_s": t,
        "x_m": c["x_m"],
        "y_m": c["y_m"],
        "z_m": c["z_m"],
        "yaw_rad": yaw,
        "qx": c["qx"],
        "qy": c["qy"],
        "qz": c["qz"],
        "qw": c["qw"],
        "speed_kmh": c["speed_kmh"],
        "steering": c["steering"],
        "accelerator": np.abs(c["gas"]),
        "brake": c["brake"],
        "engine_on": c["engine_on"],
        "gear": nan.copy(),
        "rpm": nan.copy(),
        "fuel_used_l": nan.copy(),
        "lead_gap_m": _positive_or_inf(c.get("distance_ahead_m"), inf),
        "headway_s": _positive_or_inf(c.get("headway_s"), inf),
        "ttc_s": _positive_or_inf(c.get("ttc_s"), inf),
    }
    drive = Drive(
        "cardata", p, cols, meta={"task_name": "", "driver": cd.driver, "cardata_variant": cd.variant, "driving_task": cd.driving_task}
    )
    drive.start_epoch_ms = int(c["epoch_ms"][0])
    drive.meta["created"] = cd.created
    loaded = None
    try:
        loaded = _resolve_task(p, cd, task)
    except Exception as e:
        if task is not None:
            raise
        log.warning("%s: driving task not usable: %s", p, e)
    if loaded is not None:
        drive.analysis = _task_analysis(loaded)
        drive.meta["task_name"] = loaded.name
    else:
        drive.notes.append("driving task not found: no ideal tracks or lanes")
        drive.analysis = {"guide": {"kind": "start_line"}, "lanes": [], "ideal_tracks": {}, "reaction_groups": {}}
    guide = drive.analysis["guide"]
    if guide["kind"] in ("start_line", "route"):  # no lanes, no ideal track: measure from where the log starts
        road = np.asarray(guide["polyline"], dtype=float) if guide["kind"] == "route" and guide.get("polyline") else None
        drive.analysis["guide"], why = log_reference(cols["x_m"], cols["z_m"], cols["yaw_rad"], loaded, road)
        drive.notes.append(why)
    s, lat, lane, off = locate_many(drive.analysis["guide"], cols["x_m"], cols["z_m"])
    cols.update({"s_m": s, "lateral_m": lat, "lane_index": lane, "lane_offset_m": off})
    rd = p.parent / "reactionData.xml"
    if rd.is_file():
        for r in read_reaction_data(rd):
            r["t_s"] = (r["absolute_ms"] - drive.start_epoch_ms) / 1000.0
            r.setdefault("kind", "")
            drive.reactions.append(r)
    dl = p.parent / "drivingTaskLog.txt"
    if dl.is_file():
        _, entries = read_driving_task_log(dl)
        for epoch, text in entries:
            if epoch >= 0:
                drive.events.append(
                    {"t_s": (epoch - drive.start_epoch_ms) / 1000.0, "kind": "log", "source": "drivingTaskLog", "params": {"text": text}}
                )
    return drive


def _positive_or_inf(v: np.ndarray | None, inf: np.ndarray) -> np.ndarray:
    if v is None:
        return inf.copy()
    out = np.asarray(v, dtype=float).copy()
    out[~np.isfinite(out) | (out <= 0.0)] = math.inf
    return out


def _task_analysis(task: Any) -> dict[str, Any]:
    from ..sim.guide import RoadGuide
    from ..sim.world import World, WorldConfig
    from .recorder import analysis_info

    world = World(task, WorldConfig(traffic=False))
    try:
        return analysis_info(world, RoadGuide(world))
    finally:
        world.close()


def locate_many(guide: dict[str, Any], x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(s, lateral, lane index, lane offset) of ground positions, as `RoadGuide.locate` gives them."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    lanes = np.asarray(guide.get("lane_laterals_m") or [0.0], dtype=float)
    width = float(guide.get("lane_width_m", 3.5))
    sx, sz = guide["start_xz"]
    kind = guide["kind"]
    if kind == "lanes":
        sign = float(guide["sign"])
        lat = -sign * x
        s = -sign * (z - sz)
    elif kind in ("ideal_track", "route") and guide.get("polyline"):
        poly = Polyline([tuple(p) for p in guide["polyline"]])
        proj = [poly.project(float(a), float(b)) for a, b in zip(x, z)]
        s = np.asarray([q.s_m for q in proj])
        lat = np.asarray([q.offset_m for q in proj])
    else:
        yaw = float(guide["start_yaw"])
        dx, dz = x - sx, z - sz
        s = dx * -math.sin(yaw) + dz * -math.cos(yaw)
        lat = dx * -math.cos(yaw) + dz * math.sin(yaw)
    dist = np.abs(lat[:, None] - lanes[None, :])
    nearest = np.argmin(dist, axis=1)
    lane = np.where(dist[np.arange(len(lat)), nearest] <= width / 2.0, nearest, -1).astype(float)
    if kind not in ("lanes", "route"):
        lane = np.where(np.abs(lat) < width / 2.0, 0.0, -1.0)
    off = lat - lanes[nearest]
    return s, lat, lane, off
