"""What a driver (agent, human or CAN bus) does in one physics step.

Why: every input source -- an RL action, a keyboard, a wheel, a CAN frame -- is turned
into this one record, so the simulation core never knows who is driving.
"""

from __future__ import annotations

from dataclasses import dataclass, field

# Steering wheel lock-to-centre in degrees. OpenDS's lane-change timer records the
# first |steer| >= 0.004444 and >= 0.006666 as "2 and 3 degrees" of steering, i.e. a
# full input of 1.0 is 450 degrees of steering wheel (the timer itself compares the raw
# value: see sim/triggers/reactions.py).
STEERING_WHEEL_MAX_DEG = 450.0


@dataclass
class DriverControls:
    """Inputs for one step. Steering: -1..1, positive turns left (OpenDS convention).
    Accelerator: 0..1; negative is OpenDS's "accelerate back" key (its intensity +1 in
    `SimulatorActionListener`), engine force against the gear's direction.

    `keys` and `buttons` are pressed *this step* (edge events, jME key names such as
    `KEY_A`, joystick button numbers); they feed pressKey/pressButton triggers and key
    reaction timers. Gear requests: -1 reverse, 0 neutral, 1..6 forward (manual gearbox),
    None keeps the gear.

    `steering_axis` says where the steering came from: True for an analogue axis (a
    joystick or wheel; an agent's action, which is a continuous value like a wheel's),
    False for keyboard steering (OpenDS's STEER_LEFT/STEER_RIGHT keys) and other sources
    that are not joystick axes (CAN bus, network). OpenDS's SteeringReactionTimer hears
    joystick-axis events only, so only axis steering can answer it.
    """

    steering: float = 0.0
    accelerator: float = 0.0
    brake: float = 0.0
    clutch: float = 0.0
    gear: int | None = None
    shift_up: bool = False
    shift_down: bool = False
    hand_brake: bool = False
    engine_on: bool | None = None
    toggle_automatic: bool = False
    cruise_control: bool | None = None  # True: engage at current speed, False: disengage
    cruise_speed_delta_mps: float = 0.0
    turn_signal: str | None = None  # off | left | right | both
    horn: bool = False
    keys: tuple[str, ...] = ()
    buttons: tuple[int, ...] = ()
    remote_triggers: tuple[str, ...] = ()
    reset_to: str | None = None  # reset point id
    steering_axis: bool = True

    @staticmethod
    def pedals(steering: float, accelerator: float, brake: float) -> DriverControls:
        """`DriverControls(steering=..., accelerator=..., brake=...)` without the dataclass
        constructor's cost (an agent's action becomes one every policy step)."""
        c = object.__new__(DriverControls)
        c.__dict__.update(_DEFAULTS)
        c.steering, c.accelerator, c.brake = steering, accelerator, brake
        return c

    def clipped(self) -> DriverControls:
        """A copy with pedal and steering values forced into their ranges (NaN -> 0)."""
        c = object.__new__(DriverControls)  # a plain field copy: this runs every physics step
        c.__dict__.update(self.__dict__)
        v = float(self.steering)
        c.steering = 0.0 if v != v else -1.0 if v < -1.0 else 1.0 if v > 1.0 else v  # (v != v: NaN)
        v = float(self.accelerator)
        c.accelerator = 0.0 if v != v else -1.0 if v < -1.0 else 1.0 if v > 1.0 else v
        v = float(self.brake)
        c.brake = 0.0 if v != v else 0.0 if v < 0.0 else 1.0 if v > 1.0 else v
        v = float(self.clutch)
        c.clutch = 0.0 if v != v else 0.0 if v < 0.0 else 1.0 if v > 1.0 else v
        return c


_DEFAULTS = dict(DriverControls().__dict__)  # (every default is immutable)


@dataclass
class HeldInputs:
    """Pedal/steering values as the trigger core sees them after a step (for pressPedal)."""

    steering: float = 0.0
    accelerator: float = 0.0
    brake: float = 0.0
    clutch: float = 0.0
    keys_down: set[str] = field(default_factory=set)
