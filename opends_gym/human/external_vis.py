"""Camera pose to an external visualization server (settings.xml `externalVisualization`).

Why: some labs render the scene on a separate system (OpenDS's "Lightning" client) and
only need the driver's camera from the simulator. OpenDS connects to `ip:port` over TCP
and sends, at `updateRate` Hz, either one line
`ltupdate .remotemotionsensor -posoriIn "x y z;pitch yaw roll"` (`sendPosOriAsOneString`)
or two lines (`-positionIn "x y z"`, `-orientationIn "pitch yaw roll"`). Positions are in
metres times `scalingFactor`, angles in degrees. The connection is retried in the
background and never stops the drive.
"""

from __future__ import annotations

import math
from typing import Any

from .net import ReconnectingClient
from .snapshot import VehicleSnapshot

EYE_HEIGHT_M = 1.2


def camera_pose(s: VehicleSnapshot) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The driver's eye: position (x, y, z) m and (pitch, yaw, roll) degrees."""
    return (s.x_m, s.y_m + EYE_HEIGHT_M, s.z_m), (math.degrees(s.pitch_rad), math.degrees(s.yaw_rad), math.degrees(s.roll_rad))


def format_pose(s: VehicleSnapshot, scaling: float, one_string: bool) -> str:
    (x, y, z), (p, yaw, r) = camera_pose(s)
    pos = f"{x * scaling:.4f} {y * scaling:.4f} {z * scaling:.4f}"
    ori = f"{p:.3f} {yaw:.3f} {r:.3f}"
    if one_string:
        return f'ltupdate .remotemotionsensor -posoriIn "{pos};{ori}"\n'
    return f'ltupdate .remotemotionsensor -positionIn "{pos}"\nltupdate .remotemotionsensor -orientationIn "{ori}"\n'


class ExternalVisualization:
    """Sends the camera pose at the configured rate (simulation time)."""

    def __init__(
        self, host: str, port: int, rate_hz: float = 25.0, scaling: float = 1.0, one_string: bool = False, start: bool = True
    ) -> None:
        self.period_s = 1.0 / rate_hz if rate_hz and rate_hz > 0 else 0.04
        self.scaling = scaling
        self.one_string = one_string
        self.sent = 0
        self._next_t = 0.0
        self.client = ReconnectingClient(host, port, name="external visualization")
        if start:
            self.client.start()

    @classmethod
    def from_settings(cls, block: Any) -> ExternalVisualization:
        return cls(
            block.ip or "127.0.0.1",
            int(block.port or 1234),
            rate_hz=float(block.update_rate_hz or 25.0),
            scaling=float(block.scaling_factor if block.scaling_factor is not None else 1.0),
            one_string=bool(block.send_pos_ori_as_one_string),
        )

    def update(self, s: VehicleSnapshot) -> None:
        if s.t_s + 1e-9 < self._next_t:
            return
        self._next_t = s.t_s + self.period_s
        if self.client.send(format_pose(s, self.scaling, self.one_string)):
            self.sent += 1

    @property
    def status(self) -> str:
        return self.client.state

    def close(self) -> None:
        self.client.close()
