"""Wheel and pedal calibration: dead zones and raw pedal ranges, from a YAML or JSON file.

Why: every wheel reports its axes differently (a G27's pedals rest at +1 and press to
-1; cheap pedals never reach their ends), and OpenDS's settings.xml only says which axis
is which, whether to invert it, and a sensitivity. The calibration file holds the rest,
per rig, so a lab calibrates once and every session reads the same numbers. Unknown keys
are errors (a typo must not silently leave a dead zone at 0).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class AxisCalibration:
    """One axis. Raw values are what the device reports, after settings.xml `invert`.

    For a pedal, `released_raw` and `pressed_raw` are the raw values at rest and fully
    pressed; for steering, `center_raw` is straight ahead and `lock_raw` the raw distance
    from centre at full lock. `dead_zone` is a fraction of the travel ignored at rest (or
    around the centre).
    """

    dead_zone: float = 0.0
    released_raw: float = -1.0
    pressed_raw: float = 1.0
    center_raw: float = 0.0
    lock_raw: float = 1.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"calibration value {f.name} must be a finite number, not {v!r}")
        if not 0.0 <= self.dead_zone < 1.0:
            raise ValueError(f"dead_zone must be in [0, 1), not {self.dead_zone}")
        if self.released_raw == self.pressed_raw:
            raise ValueError("released_raw and pressed_raw must differ")
        if self.lock_raw <= 0.0:
            raise ValueError("lock_raw must be positive")

    def pedal(self, raw: float) -> float:
        """Pedal travel 0..1 from a raw reading."""
        t = (raw - self.released_raw) / (self.pressed_raw - self.released_raw)
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
        if t <= self.dead_zone:
            return 0.0
        return (t - self.dead_zone) / (1.0 - self.dead_zone)

    def centred(self, raw: float) -> float:
        """-1..1 around the centre (steering, combined pedals), with the dead zone removed."""
        v = (raw - self.center_raw) / self.lock_raw
        v = -1.0 if v < -1.0 else 1.0 if v > 1.0 else v
        if abs(v) <= self.dead_zone:
            return 0.0
        return math.copysign((abs(v) - self.dead_zone) / (1.0 - self.dead_zone), v)


@dataclass(frozen=True)
class Calibration:
    """The axes of one rig (see the shipped example, `--calibration wheel_calibration`)."""

    steering: AxisCalibration = field(default_factory=AxisCalibration)
    combined_pedals: AxisCalibration = field(default_factory=AxisCalibration)
    accelerator: AxisCalibration = field(default_factory=AxisCalibration)
    brake: AxisCalibration = field(default_factory=AxisCalibration)
    clutch: AxisCalibration = field(default_factory=AxisCalibration)


_AXES = tuple(f.name for f in dataclasses.fields(Calibration))
_AXIS_KEYS = tuple(f.name for f in dataclasses.fields(AxisCalibration))


def calibration_from_dict(data: dict[str, Any], source: str = "<calibration>") -> Calibration:
    """Build a Calibration; unknown axes or keys raise ValueError naming the file."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: the calibration must be a mapping of axis names")
    unknown = sorted(set(data) - set(_AXES))
    if unknown:
        raise ValueError(f"{source}: unknown axis {', '.join(unknown)}; valid: {', '.join(_AXES)}")
    axes: dict[str, AxisCalibration] = {}
    for axis, values in data.items():
        if not isinstance(values, dict):
            raise ValueError(f"{source}: '{axis}' must be a mapping")
        bad = sorted(set(values) - set(_AXIS_KEYS))
        if bad:
            raise ValueError(f"{source}: unknown key {', '.join(bad)} in '{axis}'; valid: {', '.join(_AXIS_KEYS)}")
        try:
            axes[axis] = AxisCalibration(**values)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{source}: '{axis}': {e}") from None
    return Calibration(**axes)


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration from YAML (`.yaml`/`.yml`) or JSON; `wheel_calibration` names the shipped example."""
    from ...resources import resolve_calibration

    p = resolve_calibration(path)
    text = p.read_text(encoding="utf-8")
    if p.suffix.lower() in (".yaml", ".yml"):
        import yaml

        data = yaml.safe_load(text) or {}
    else:
        data = json.loads(text)
    return calibration_from_dict(data, str(p))
