"""OpenDS `carData.txt` drive recordings: read every known variant, write the classic one.

Why: labs have years of OpenDS recordings; the analyzer must read them, and OpenDS's
Drive Analyzer must read ours. The file (`eu.opends.analyzer.DataWriter`) is a header --
`Driving Task: <path>`, `Date-Time: yyyy_MM_dd-HH_mm_ss` (2023: `Creation Time:
yyyy-MM-dd HH:mm:ss.SSS`), `Driver: <name>`, `Used Format = ...` -- then one row per
50 ms, colon-separated:

* classic: `epoch_ms:x:y:z:qx:qy:qz:qw:speed_kmh:steering:gas:brake:engineOn`;
* Oculus Rift attached: + head yaw (deg, + right) and head pitch (deg, + up);
* 2023 (AnnegretJ/openDS): a formatted `yyyy-MM-dd HH.mm.ss.SSS` after epoch_ms, and the
  front position (x, y, z) and the reference-object data appended;
* batheja fork: + distance ahead (m), time to collision (s), headway (s) (then Oculus).

OpenDS writes Java floats (`1.0E-4` style, `NaN`, `Infinity`), all of which Python reads.
The variant is taken from the `Used Format` line, else from the row layout.
"""

from __future__ import annotations

import datetime as _dt
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

CLASSIC = ("epoch_ms", "x_m", "y_m", "z_m", "qx", "qy", "qz", "qw", "speed_kmh", "steering", "gas", "brake", "engine_on")
HEAD = ("head_yaw_deg", "head_pitch_deg")
FRONT = ("front_x_m", "front_y_m", "front_z_m")
BATHEJA = ("distance_ahead_m", "ttc_s", "headway_s")
VARIANTS = ("classic", "oculus", "2023", "batheja", "batheja_oculus")
CLASSIC_FORMAT = (
    "Used Format = Time (ms) : Position (x,y,z) : Rotation (x,y,z,w) : Speed (km/h) : Steering Wheel Position [-1,1] :"
    " Gas Pedal Position : Brake Pedal Position : Engine Running"
)


@dataclass
class CarData:
    """A carData.txt file: its header and one array per column (NaN where a row lacks it)."""

    path: Path | None
    variant: str
    driving_task: str = ""
    created: str = ""  # as written (Date-Time or Creation Time)
    driver: str = ""
    format_line: str = ""
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    timestamps: list[str] = field(default_factory=list)  # 2023's formatted timestamps
    reference_objects: list[str] = field(default_factory=list)  # 2023's reference-object data, raw

    @property
    def n(self) -> int:
        return len(self.columns.get("epoch_ms", ()))

    def t_s(self) -> np.ndarray:
        """Seconds since the first row (OpenDS rows carry wall-clock epoch milliseconds)."""
        e = self.columns["epoch_ms"]
        return (e - e[0]) / 1000.0 if len(e) else e


# What Java's Float/Double.toString and Boolean.toString write (OpenDS builds rows by string
# concatenation): ASCII decimals, NaN and Infinity; `1_0` or non-ASCII digits are damage.
_JAVA_NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|NaN|Infinity)", re.ASCII)
_FLOAT_MAX = 3.4028234663852886e38  # Float.MAX_VALUE: no OpenDS float column exceeds it


def _float(text: str) -> float:
    t = text.strip()
    if t in ("true", "false"):
        return 1.0 if t == "true" else 0.0
    if len(t) > 64 or not _JAVA_NUMBER.fullmatch(t):
        raise ValueError(f"could not convert {t[:40]!r} to a number (ASCII decimals, NaN or Infinity)")
    v = float(t)
    if math.isfinite(v) and abs(v) > _FLOAT_MAX:
        raise ValueError(f"could not convert {t[:40]!r}: beyond the range of a Java float")
    return v


def _variant_from_format(fmt: str) -> str | None:
    if not fmt:
        return None
    f = fmt.lower()
    if "timestamp" in f:
        return "2023"
    if "distance ahead" in f:
        return "batheja_oculus" if "oculusrift" in f else "batheja"
    if "oculusrift" in f:
        return "oculus"
    return "classic"


def _variant_from_row(parts: list[str]) -> str:
    try:
        float(parts[1])
    except (ValueError, IndexError):
        return "2023"  # a formatted timestamp in the second field
    return {13: "classic", 15: "oculus", 16: "batheja", 18: "batheja_oculus"}.get(len(parts), "classic")


def _layout(variant: str) -> tuple[str, ...]:
    return {
        "classic": CLASSIC,
        "oculus": CLASSIC + HEAD,
        "batheja": CLASSIC + BATHEJA,
        "batheja_oculus": CLASSIC + BATHEJA + HEAD,
        "2023": CLASSIC + FRONT,
    }[variant]


def _parse_row(line: str, variant: str, where: str) -> tuple[list[float], str, str]:
    """Values in `_layout(variant)` order, plus 2023's timestamp and reference data."""
    stamp = ref = ""
    if variant == "2023":
        parts = line.split(":", 17)
        if len(parts) < 17:
            raise ValueError(f"{where}: expected at least 17 ':'-separated fields (2023 layout), found {len(parts)}")
        stamp = parts.pop(1)
        ref = parts.pop(16) if len(parts) > 16 else ""
    else:
        parts = line.split(":")
        need = len(_layout(variant))
        if len(parts) != need:
            raise ValueError(f"{where}: expected {need} ':'-separated fields ({variant} layout), found {len(parts)}")
    try:
        values = [_float(p) for p in parts]
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
    return values, stamp.strip(), ref.strip()


def read_cardata(path: str | Path) -> CarData:
    """Read a carData.txt of any known variant (see the module docstring).

    A malformed row is an error naming the file and line, except a torn last row (OpenDS
    killed mid-write), which is skipped with a warning.
    """
    p = Path(path)
    text = p.read_text(encoding="utf-8", errors="replace")
    lines = text.splitlines()
    cd = CarData(p, "classic")
    body_start = 0
    for i, line in enumerate(lines[:6]):
        key, sep, value = line.partition(":")
        if line.startswith("Used Format"):
            cd.format_line = line
            body_start = i + 1
        elif sep and key.strip() in ("Driving Task", "Date-Time", "Creation Time", "Driver"):
            v = value.strip()
            if key.strip() == "Driving Task":
                cd.driving_task = v
            elif key.strip() == "Driver":
                cd.driver = v
            else:
                cd.created = v
            body_start = i + 1
    rows = [(k, ln.strip()) for k, ln in enumerate(lines[body_start:], start=body_start + 1) if ln.strip()]
    variant = _variant_from_format(cd.format_line) or (_variant_from_row(rows[0][1].split(":")) if rows else "classic")
    cd.variant = variant
    layout = _layout(variant)
    data: list[list[float]] = []
    for idx, (lineno, line) in enumerate(rows):
        try:
            values, stamp, ref = _parse_row(line, variant, f"{p}:{lineno}")
        except ValueError:
            if idx == len(rows) - 1 and data:
                log.warning("%s:%d: torn last row skipped", p, lineno)
                break
            raise
        data.append(values)
        if variant == "2023":
            cd.timestamps.append(stamp)
            cd.reference_objects.append(ref)
    arr = np.asarray(data, dtype=float).reshape(-1, len(layout))
    cd.columns = {name: arr[:, j].copy() for j, name in enumerate(layout)}
    return cd


# ------------------------------------------------------------------ writing
def _num(v: float, digits: int) -> str:
    if not math.isfinite(v):
        return "NaN" if math.isnan(v) else ("Infinity" if v > 0 else "-Infinity")
    r = round(float(v), digits)
    return repr(r + 0.0)  # + 0.0 turns -0.0 into 0.0


def write_cardata(
    path: str | Path,
    t_s: np.ndarray,
    x_m: np.ndarray,
    y_m: np.ndarray,
    z_m: np.ndarray,
    quaternion: np.ndarray,
    speed_kmh: np.ndarray,
    steering: np.ndarray,
    gas: np.ndarray,
    brake: np.ndarray,
    engine_on: np.ndarray,
    *,
    driving_task: str = "",
    driver: str = "",
    start_epoch_ms: int = 0,
    rate_hz: float = 20.0,
) -> Path:
    """Write the classic variant (OpenDS 4.x/CTS), resampled to `rate_hz` like OpenDS (20 Hz).

    Rows are the samples at the first sample time of each 1/rate_hz slot; positions are
    rounded to 1 mm, the quaternion to 1e-4 and steering to 1e-5, as OpenDS does. The epoch
    is `start_epoch_ms` + simulation milliseconds. Returns the path written.
    """
    t = np.asarray(t_s, dtype=float)
    slot = np.floor(t * rate_hz + 1e-9).astype(np.int64)
    pick = np.flatnonzero(np.concatenate([[True], slot[1:] != slot[:-1]])) if len(t) else np.array([], dtype=int)
    created = _dt.datetime.fromtimestamp(start_epoch_ms / 1000.0)  # local time, as OpenDS writes it
    q = np.asarray(quaternion, dtype=float).reshape(-1, 4)
    out = [
        f"Driving Task: {driving_task}",
        f"Date-Time: {created.strftime('%Y_%m_%d-%H_%M_%S')}",
        f"Driver: {driver}",
        CLASSIC_FORMAT,
    ]
    for i in pick:
        epoch = start_epoch_ms + int(round(t[i] * 1000.0))
        fields = [
            str(epoch),
            _num(x_m[i], 3),
            _num(y_m[i], 3),
            _num(z_m[i], 3),
            *(_num(q[i, k], 4) for k in range(4)),
            _num(speed_kmh[i], 2),
            _num(steering[i], 5),
            _num(abs(gas[i]), 4),
            _num(brake[i], 4),
            "true" if engine_on[i] else "false",
        ]
        out.append(":".join(fields))
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("\n".join(out) + "\n", encoding="utf-8")
    return p


def cardata_as_dict(cd: CarData) -> dict[str, Any]:
    return {"variant": cd.variant, "driving_task": cd.driving_task, "created": cd.created, "driver": cd.driver, "rows": cd.n}
