"""Joysticks and steering wheels (pygame-ce / SDL2) as an input source.

Why: a human-factors lab drives with a wheel and pedals. settings.xml says which
controller and axis is the steering, the combined or separate pedals and the clutch,
with inversion and sensitivity (OpenDS's `controllers/joystick`); a calibration file
adds dead zones and pedal ranges. Buttons become `pressButton` triggers and `JOY_n` keys
for key reaction timers, and `joystick/keyAssignments` (`BUTTON_n`) map them to OpenDS
functions. Unplugging the wheel mid-drive holds the drive with a message (the source
reports itself `blocking`) and plugging it back in resumes it; nothing raises.

Devices come from a backend: `PygameJoysticks` for real hardware, `FakeJoystick`s for
tests (they behave like pygame joysticks, including raising when unplugged).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Protocol

from .base import InputFrame, InputStatus
from .calibration import AxisCalibration, Calibration
from .keyboard import CRUISE_STEP_MPS
from .keys import RUNNER_FUNCTIONS, invert_table, key_table

log = logging.getLogger(__name__)


class JoystickDevice(Protocol):
    def get_instance_id(self) -> int: ...
    def get_name(self) -> str: ...
    def get_numaxes(self) -> int: ...
    def get_axis(self, axis: int) -> float: ...
    def get_numbuttons(self) -> int: ...
    def get_button(self, button: int) -> bool: ...


class JoystickBackend(Protocol):
    def devices(self) -> list[JoystickDevice]: ...


@dataclass(frozen=True)
class AxisMap:
    """settings.xml `controllerID@axisID@invert@sensitivity` of one function."""

    controller_id: int
    axis_id: int
    invert: bool = False
    sensitivity: float = 1.0


DEFAULT_STEERING = AxisMap(0, 0)
RESCAN_EVERY_POLLS = 15  # a missing controller is looked for every 15 polls (a quarter second at 60 Hz)
DEFAULT_COMBINED = AxisMap(0, 1)


class FakeJoystick:
    """A joystick for tests: set `axes`/`buttons`; `attached=False` makes reads raise."""

    def __init__(self, name: str = "Fake Wheel", axes: int = 4, buttons: int = 16, instance_id: int = 0) -> None:
        self.name = name
        self.axes = [0.0] * axes
        self.buttons = [False] * buttons
        self.instance_id = instance_id
        self.attached = True

    def _check(self) -> None:
        if not self.attached:
            raise RuntimeError(f"joystick '{self.name}' is not attached")

    def get_instance_id(self) -> int:
        return self.instance_id

    def get_name(self) -> str:
        return self.name

    def get_numaxes(self) -> int:
        self._check()
        return len(self.axes)

    def get_axis(self, axis: int) -> float:
        self._check()
        return self.axes[axis]

    def get_numbuttons(self) -> int:
        self._check()
        return len(self.buttons)

    def get_button(self, button: int) -> bool:
        self._check()
        return self.buttons[button]


class FakeJoystickBackend:
    """The list of plugged-in fake joysticks (tests plug and unplug them)."""

    def __init__(self, *joysticks: FakeJoystick) -> None:
        self.plugged = list(joysticks)

    def devices(self) -> list[JoystickDevice]:
        return [j for j in self.plugged if j.attached]


class PygameJoysticks:
    """Real devices through pygame-ce (SDL2). Call `pygame.init()` or a window first."""

    def __init__(self) -> None:
        import os

        os.environ.setdefault("SDL_JOYSTICK_ALLOW_BACKGROUND_EVENTS", "1")
        import pygame

        pygame.joystick.init()

    def devices(self) -> list[JoystickDevice]:
        import pygame

        out: list[JoystickDevice] = []
        for i in range(pygame.joystick.get_count()):
            try:
                js = pygame.joystick.Joystick(i)
                js.init()
                out.append(js)
            except pygame.error as e:  # a device vanishing while we enumerate
                log.warning("joystick %d cannot be opened: %s", i, e)
        return out


def axis_maps_from_settings(settings: Any) -> dict[str, AxisMap]:
    """Function -> AxisMap from settings `controllers/joystick` (defaults when absent)."""
    js = getattr(getattr(settings, "controllers", None), "joystick", None)
    out: dict[str, AxisMap] = {}
    for func in ("steering", "combined_pedals", "accelerator", "brake", "clutch"):
        a = getattr(js, func, None) if js is not None else None
        if a is not None:
            out[func] = AxisMap(int(a.controller_id), int(a.axis_id), bool(a.invert), float(a.sensitivity))
    out.setdefault("steering", DEFAULT_STEERING)
    if not any(k in out for k in ("combined_pedals", "accelerator", "brake")):
        out["combined_pedals"] = DEFAULT_COMBINED
    return out


class JoystickSource:
    """Wheel/joystick driving (see the module docstring)."""

    name = "joystick"

    def __init__(
        self,
        backend: JoystickBackend,
        axes: dict[str, AxisMap] | None = None,
        calibration: Calibration | None = None,
        assignments: Any = (),
        dump_list: bool = False,
    ) -> None:
        self.backend = backend
        self.axes = dict(axes or {"steering": DEFAULT_STEERING, "combined_pedals": DEFAULT_COMBINED})
        self.calibration = calibration or Calibration()
        table = {f: tuple(k for k in keys if k.startswith("BUTTON_")) for f, keys in key_table(assignments).items()}
        self.by_button = {int(k[7:]): funcs for k, funcs in invert_table(table).items() if k[7:].isdigit()}
        self.needed = sorted({m.controller_id for m in self.axes.values()})
        self.devices: dict[int, JoystickDevice] = {}
        self._buttons_down: dict[int, set[int]] = {}
        self._message = ""
        self._polls_missing = 0
        self.rescan()
        if dump_list:
            for i, d in self.devices.items():
                log.warning("joystick %d: %s (%d axes, %d buttons)", i, d.get_name(), d.get_numaxes(), d.get_numbuttons())

    @classmethod
    def from_settings(cls, settings: Any, backend: JoystickBackend, calibration: Calibration | None = None) -> JoystickSource:
        js = getattr(getattr(settings, "controllers", None), "joystick", None)
        return cls(
            backend,
            axis_maps_from_settings(settings),
            calibration,
            getattr(js, "key_assignments", ()) if js is not None else (),
            bool(getattr(js, "dump_joystick_list", False)) if js is not None else False,
        )

    # ------------------------------------------------------------------ devices
    def rescan(self) -> None:
        """Re-enumerate devices (at start and when one is plugged in)."""
        try:
            found = self.backend.devices()
        except Exception as e:  # enumeration must never end the drive
            log.warning("joystick enumeration failed: %s", e)
            found = []
        before = set(self.devices)
        self.devices = dict(enumerate(found))
        for i in set(self.devices) - before:
            log.info("joystick %d connected: %s", i, self.devices[i].get_name())
            self._buttons_down[i] = set()

    def handle_event(self, event: Any) -> bool:
        """pygame JOYDEVICEADDED / JOYDEVICEREMOVED: re-enumerate."""
        import pygame

        if event.type in (pygame.JOYDEVICEADDED, pygame.JOYDEVICEREMOVED):
            self.rescan()
            return True
        return False

    def _lost(self, controller: int, err: Exception) -> None:
        dev = self.devices.pop(controller, None)
        name = dev.get_name() if dev is not None else f"#{controller}"
        self._message = f"Controller {controller} ({name}) disconnected - plug it back in to continue"
        log.warning("joystick %s lost: %s", name, err)

    # ------------------------------------------------------------------ polling
    def _axis(self, func: str) -> float | None:
        m = self.axes.get(func)
        if m is None:
            return None
        dev = self.devices.get(m.controller_id)
        if dev is None:
            return None
        try:
            if m.axis_id >= dev.get_numaxes():
                return None
            raw = float(dev.get_axis(m.axis_id))
        except Exception as e:
            self._lost(m.controller_id, e)
            return None
        if raw != raw:
            return None
        return -raw if m.invert else raw

    def _cal(self, func: str) -> AxisCalibration:
        return getattr(self.calibration, func)

    def poll(self, t_s: float) -> InputFrame:
        f = InputFrame()
        if any(c not in self.devices for c in self.needed):
            self._polls_missing += 1  # a backend without hot-plug events still recovers
            if self._polls_missing % RESCAN_EVERY_POLLS == 1:
                self.rescan()
            if any(c not in self.devices for c in self.needed):
                return f
        raw = self._axis("steering")
        if raw is not None:
            # a wheel turned right reads positive; OpenDS steering is + to the left
            f.steering = _clamp(-self._cal("steering").centred(raw) * self.axes["steering"].sensitivity, -1.0, 1.0)
            f.steering_axis = True
        acc, brk = self._axis("accelerator"), self._axis("brake")
        if acc is not None:
            f.accelerator = _clamp(self._cal("accelerator").pedal(acc) * self.axes["accelerator"].sensitivity, 0.0, 1.0)
        if brk is not None:
            f.brake = _clamp(self._cal("brake").pedal(brk) * self.axes["brake"].sensitivity, 0.0, 1.0)
        if acc is None and brk is None:
            comb = self._axis("combined_pedals")
            if comb is not None:
                v = self._cal("combined_pedals").centred(comb) * self.axes["combined_pedals"].sensitivity
                f.accelerator = _clamp(v, 0.0, 1.0)
                f.brake = _clamp(-v, 0.0, 1.0)
        clutch = self._axis("clutch")
        if clutch is not None:
            f.clutch = _clamp(self._cal("clutch").pedal(clutch) * self.axes["clutch"].sensitivity, 0.0, 1.0)
        self._poll_buttons(f)
        if not any(c not in self.devices for c in self.needed):
            self._message = ""
            self._polls_missing = 0
        return f

    def _poll_buttons(self, f: InputFrame) -> None:
        pressed: list[int] = []
        commands: list[str] = []
        for c, dev in list(self.devices.items()):
            down = self._buttons_down.setdefault(c, set())
            try:
                now = {b for b in range(dev.get_numbuttons()) if dev.get_button(b)}
            except Exception as e:
                self._lost(c, e)
                continue
            if c == 0:  # OpenDS's pressButton and JOY_n refer to joystick 0
                pressed.extend(sorted(now - down))
            self._buttons_down[c] = now
        for b in pressed:
            for func in self.by_button.get(b, ()):
                if func in RUNNER_FUNCTIONS or func.startswith("reset_car"):
                    commands.append(func)
                elif func.startswith("gear"):
                    f.gear = -1 if func == "gearR" else int(func[4:])
                elif func in ("shift_up", "shift_down", "toggle_automatic", "toggle_engine"):
                    setattr(f, func, True)
                elif func in ("cruise_control", "toggle_min_speed"):
                    f.toggle_cruise = True
                elif func in ("cc_inc5", "cc_dec5"):
                    f.cruise_speed_delta_mps += CRUISE_STEP_MPS if func == "cc_inc5" else -CRUISE_STEP_MPS
        f.buttons = tuple(pressed)
        f.keys = tuple(f"JOY_{b}" for b in pressed)
        f.commands = tuple(commands)

    def status(self) -> InputStatus:
        missing = [c for c in self.needed if c not in self.devices]
        if missing:
            msg = self._message or f"No joystick for controller {missing[0]} - plug in the wheel to continue"
            return InputStatus(self.name, connected=False, message=msg, blocking=True)
        return InputStatus(self.name)

    def close(self) -> None:
        self.devices.clear()


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v
