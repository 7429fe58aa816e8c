"""From merged device input to the explicit `DriverControls` of one physics step.

Why: devices speak in toggles and intentions ("cruise control on/off", "reverse",
"next reset point", "automatic gearbox: true"); the simulation takes explicit values.
Resolving them here, against the car's current state and on the simulation thread,
makes every recorded `DriverControls` self-contained, so a replay needs no device.
"""

from __future__ import annotations

from typing import Any

from ..sim.controls import DriverControls
from .inputs.base import InputFrame

REVERSE_SWITCH_MPS = 0.5  # reverse (or forward) is engaged only this slow; faster, the pedal brakes


class ControlsBuilder:
    """Turns `InputFrame`s into `DriverControls` for one World."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.reset_ids = tuple(world.reset_poses)
        self.hand_brake = False
        self._last_reset = -1

    def reset_target(self, command: str) -> str | None:
        """`reset_car` cycles through the reset points; `reset_car_posN` picks the N-th."""
        if not self.reset_ids:
            return None
        if command == "reset_car":
            self._last_reset = (self._last_reset + 1) % len(self.reset_ids)
        else:
            n = int(command.removeprefix("reset_car_pos")) - 1
            if not 0 <= n < len(self.reset_ids):
                return None
            self._last_reset = n
        return self.reset_ids[self._last_reset]

    def build(self, f: InputFrame) -> DriverControls:
        ego = self.world.ego
        pt = ego.powertrain.state
        v = ego.state.u
        c = DriverControls(
            steering=f.steering if f.steering is not None else 0.0,
            accelerator=f.accelerator if f.accelerator is not None else 0.0,
            brake=f.brake if f.brake is not None else 0.0,
            clutch=f.clutch if f.clutch is not None else 0.0,
            gear=f.gear,
            shift_up=f.shift_up,
            shift_down=f.shift_down,
            horn=bool(f.horn),
            turn_signal=f.turn_signal,
            keys=f.keys,
            buttons=f.buttons,
            remote_triggers=f.remote_triggers,
            cruise_speed_delta_mps=f.cruise_speed_delta_mps,
            steering_axis=bool(f.steering_axis),  # CAN, network and no steering at all: not an axis
        )
        if f.toggle_hand_brake:
            self.hand_brake = not self.hand_brake
        if f.hand_brake is not None:
            self.hand_brake = bool(f.hand_brake)
        c.hand_brake = self.hand_brake
        if f.automatic is not None:
            c.toggle_automatic = bool(f.automatic) != bool(pt.automatic)
        elif f.toggle_automatic:
            c.toggle_automatic = True
        if f.engine_on is not None:
            c.engine_on = bool(f.engine_on)
        elif f.toggle_engine:
            c.engine_on = not pt.engine_on
        if f.toggle_cruise:
            c.cruise_control = not ego.cruise_active
        if f.reverse is not None and c.gear is None:
            want_reverse = bool(f.reverse)
            in_reverse = pt.gear < 0
            if want_reverse != in_reverse and c.accelerator > 0.0:
                if abs(v) < REVERSE_SWITCH_MPS:
                    c.gear = -1 if want_reverse else 1
                else:  # still rolling the other way: the pedal brakes first
                    c.brake = max(c.brake, c.accelerator)
                    c.accelerator = 0.0
        if f.reset_to is not None:
            c.reset_to = f.reset_to
        for cmd in f.commands:
            if cmd.startswith("reset_car"):
                target = self.reset_target(cmd)
                if target is not None:
                    c.reset_to = target
        return c
