"""Build the input sources a `DriveConfig` asks for, from the task's settings.xml.

Why: the device mapping lives in the task (settings.xml `controllers`, `CANInterface`,
`settingsControllerServer`), the choice of device on the command line. Keeping the glue
here lets the runner stay a loop.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field
from typing import Any

from .inputs.base import InputCombiner, InputSource
from .session_config import DriveConfig

log = logging.getLogger(__name__)


@dataclass
class Sources:
    combiner: InputCombiner
    keyboard: Any = None
    joystick: Any = None
    feedback: list[Any] = field(default_factory=list)  # sources with feedback(snapshot)
    server: Any = None

    @property
    def needs_pygame_events(self) -> bool:
        return self.keyboard is not None or self.joystick is not None


def remote_ids_of(task: Any) -> set[str]:
    """The ids of the task's `remote:` conditions (what the settings controller may fire)."""
    from ..task.conditions import Remote

    return {c.trigger_id for t in task.interaction.triggers for c in t.condition.items if isinstance(c, Remote)}


def build_sources(config: DriveConfig, task: Any, joystick_backend: Any = None) -> Sources:
    """Sources in priority order: network and wheel first, the keyboard last (held keys win)."""
    settings = task.settings
    can = settings.can_interface
    max_deg = math.degrees(can.max_steering_angle_rad)
    out = Sources(InputCombiner())
    ordered: list[InputSource] = []
    for spec in config.inputs:
        if spec.kind == "can-tcp":
            from .inputs.can_gateway import CanGatewaySource

            ordered.append(CanGatewaySource.from_settings(settings, spec.host, spec.port))
            out.feedback.append(ordered[-1])
        elif spec.kind == "can-bus":
            from .inputs.can_bus import DEFAULT_DBC, CanBusSource

            src = CanBusSource(
                spec.interface or "socketcan",
                spec.channel or "can0",
                dbc=config.dbc or DEFAULT_DBC,
                max_steering_deg=max_deg,
                update_rate_hz=float(can.update_rate_hz),
            )
            ordered.append(src)
            out.feedback.append(src)
        elif spec.kind == "joystick":
            from .inputs.calibration import load_calibration
            from .inputs.joystick import JoystickSource, PygameJoysticks

            cal = load_calibration(config.calibration) if config.calibration else None
            out.joystick = JoystickSource.from_settings(settings, joystick_backend or PygameJoysticks(), cal)
            ordered.append(out.joystick)
    server_on = config.settings_server if config.settings_server is not None else settings.settings_controller_server.start_server
    if server_on:
        from .settings_server import SettingsControllerServer

        port = config.server_port if config.server_port is not None else settings.settings_controller_server.port
        ids = remote_ids_of(task)
        try:
            token = os.environ.get(config.server_token_env) if config.server_token_env else None
            if config.server_token_env and not token:
                raise ValueError(f"--server-token-env {config.server_token_env}: that environment variable is empty or unset")
            out.server = SettingsControllerServer(
                config.server_host, port, remote_ids=lambda: ids, control_token=token, control_peers=config.server_control_peers
            ).start()
            ordered.append(out.server)
        except OSError as e:  # port taken or privileged: the drive goes on without the server
            log.error("settings-controller server not started on %s:%s: %s", config.server_host, port, e)
    if any(s.kind == "keyboard" for s in config.inputs):
        from .inputs.keyboard import KeyboardSource

        out.keyboard = KeyboardSource.from_settings(settings)
        ordered.append(out.keyboard)
    for s in ordered:
        out.combiner.add(s)
    return out
