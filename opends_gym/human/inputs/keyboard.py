"""The keyboard as an input source, with OpenDS's function ids and settings.xml overrides.

Why: OpenDS participants drive with the arrow keys and press G to report a reaction;
experimenters remap keys in settings.xml (`controllers/keyboard/keyAssignments`). Every
key press also goes to the simulation as a jME key name, so `pressKey` triggers and key
reaction timers fire from it exactly as in OpenDS. The source works from key events
(`handle_key`, or `handle_event` for pygame events), so tests drive it with synthetic
presses and no window.
"""

from __future__ import annotations

from typing import Any

from ...task.conditions import canonical_key
from .base import InputFrame, InputStatus
from .keys import RUNNER_FUNCTIONS, invert_table, jme_key_name, key_table

KEY_STEER = 0.3  # OpenDS steers by +-0.3 per held arrow key
CRUISE_STEP_MPS = 5.0 / 3.6  # cc_inc5 / cc_dec5


class KeyboardSource:
    """Keyboard driving (see the module docstring). Priority: put it last so held keys win."""

    name = "keyboard"

    def __init__(self, assignments: Any = (), steer_step: float = KEY_STEER) -> None:
        self.table = key_table(assignments)
        self.by_key = invert_table(self.table)
        self.steer_step = steer_step
        self.down: set[str] = set()
        self._pressed: list[str] = []
        self._signal = "off"
        self._signal_changed = False

    @classmethod
    def from_settings(cls, settings: Any) -> KeyboardSource:
        kb = getattr(getattr(settings, "controllers", None), "keyboard", None)
        return cls(getattr(kb, "key_assignments", ()) if kb is not None else ())

    # ------------------------------------------------------------------ events
    def handle_key(self, key: str, down: bool) -> None:
        """A key went down or up (jME name, `KEY_` prefix optional)."""
        k = canonical_key(key)
        if down:
            if k not in self.down:  # auto-repeat is not a new press
                self._pressed.append(k)
            self.down.add(k)
        else:
            self.down.discard(k)

    def handle_event(self, event: Any) -> bool:
        """A pygame KEYDOWN/KEYUP event; True when it was a mapped key."""
        import pygame

        if event.type not in (pygame.KEYDOWN, pygame.KEYUP):
            return False
        name = jme_key_name(int(event.key))
        if name is None:
            return False
        self.handle_key(name, event.type == pygame.KEYDOWN)
        return True

    def release_all(self) -> None:
        """Forget held keys (the window lost focus: no key-up events will come)."""
        self.down.clear()

    # ------------------------------------------------------------------ polling
    def _held(self, function: str) -> bool:
        return any(k in self.down for k in self.table.get(function, ()))

    def poll(self, t_s: float) -> InputFrame:
        f = InputFrame()
        left, right = self._held("steer_left"), self._held("steer_right")
        if left or right:
            f.steering = self.steer_step * (float(left) - float(right))
            f.steering_axis = False  # keys are no joystick axis (SteeringReactionTimer ignores them)
        if self._held("accelerate") or self._held("accelerate_back"):
            f.accelerator = 1.0
            f.reverse = self._held("accelerate_back") and not self._held("accelerate")
        if self._held("brake"):
            f.brake = 1.0
        if self._held("horn"):
            f.horn = True
        pressed, self._pressed = self._pressed, []
        commands: list[str] = []
        for k in pressed:
            for func in self.by_key.get(k, ()):
                self._press_function(func, f, commands)
        f.keys = tuple(pressed)
        f.commands = tuple(commands)
        if self._signal_changed:
            f.turn_signal = self._signal
            self._signal_changed = False
        return f

    def _press_function(self, func: str, f: InputFrame, commands: list[str]) -> None:
        if func in RUNNER_FUNCTIONS or func.startswith("reset_car"):
            commands.append(func)
        elif func == "shift_up":
            f.shift_up = True
        elif func == "shift_down":
            f.shift_down = True
        elif func == "toggle_automatic":
            f.toggle_automatic = True
        elif func == "toggle_engine":
            f.toggle_engine = True
        elif func in ("cruise_control", "toggle_min_speed"):
            f.toggle_cruise = True
        elif func == "cc_inc5":
            f.cruise_speed_delta_mps += CRUISE_STEP_MPS
        elif func == "cc_dec5":
            f.cruise_speed_delta_mps -= CRUISE_STEP_MPS
        elif func == "toggle_handbrake":
            f.toggle_hand_brake = True
        elif func in ("turn_left", "turn_right", "hazard_lights"):
            want = {"turn_left": "left", "turn_right": "right", "hazard_lights": "both"}[func]
            self._signal = "off" if self._signal == want else want
            self._signal_changed = True
        elif func.startswith("gear"):
            f.gear = -1 if func == "gearR" else int(func[4:])
        # report_reaction and other ids act through the key itself (pressKey, key timers)

    def status(self) -> InputStatus:
        return InputStatus(self.name)

    def close(self) -> None:
        self.down.clear()
