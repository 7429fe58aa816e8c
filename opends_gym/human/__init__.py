"""Human-in-the-loop driving: real-time runner, input devices, settings-controller server.

Why: a participant at a wheel must drive the same env an agent drives, get the same
metrics and leave the same recording. Nothing here is imported by the envs.

* `inputs`: `InputSource` and the keyboard, joystick/wheel, CAN gateway (TCP) and CAN bus
  (python-can + cantools) sources.
* `settings_server.SettingsControllerServer`: OpenDS's XML control protocol.
* `runner.DriveSession`: the real-time loop (`opends-gym drive`).
"""

from __future__ import annotations

__all__: list[str] = []
