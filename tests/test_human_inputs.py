"""Keyboard and joystick/wheel sources: OpenDS key table, settings.xml overrides, axis
mapping, calibration, unplug/replug, and pressKey/pressButton triggers in a real session."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from opends_gym.human.inputs.base import InputFrame, merge_frames
from opends_gym.human.inputs.calibration import AxisCalibration, Calibration, load_calibration
from opends_gym.human.inputs.joystick import AxisMap, FakeJoystick, FakeJoystickBackend, JoystickSource, axis_maps_from_settings
from opends_gym.human.inputs.keyboard import KeyboardSource
from opends_gym.human.inputs.keys import DEFAULT_KEYS, key_table
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig, InputSpec
from opends_gym.task import load_task
from opends_gym.task.model_settings import KeyAssignment
from tests.human_helpers import reaction_test_with_extra_triggers

ROOT = Path(__file__).resolve().parent.parent


# ---------------------------------------------------------------------- keyboard
def test_default_key_table_matches_opends() -> None:
    assert DEFAULT_KEYS["accelerate"] == ("KEY_UP",)
    assert DEFAULT_KEYS["brake"] == ("KEY_SPACE",)
    assert DEFAULT_KEYS["toggle_pause"] == ("KEY_P",)
    assert DEFAULT_KEYS["report_reaction"] == ("KEY_G", "BUTTON_8")
    assert DEFAULT_KEYS["reset_car_pos10"] == ("KEY_0",)
    assert DEFAULT_KEYS["shift_up"] == ("KEY_PGUP",)


def test_settings_overrides_replace_defaults_and_accumulate() -> None:
    table = key_table([KeyAssignment("close_instruction_screen", "SPACE"), KeyAssignment("horn", "KEY_B"), KeyAssignment("horn", "n")])
    assert table["close_instruction_screen"] == ("KEY_SPACE",)  # F5 is gone, "SPACE" is canonical
    assert table["horn"] == ("KEY_B", "KEY_N")
    assert table["accelerate"] == ("KEY_UP",)


def test_keyboard_from_real_settings_xml(corpus: Path) -> None:
    task = load_task(corpus / "opends-cts/ReactionTest")
    kb = KeyboardSource.from_settings(task.settings)
    kb.handle_key("SPACE", True)  # settings: close_instruction_screen=SPACE; SPACE still brakes
    f = kb.poll(0.0)
    assert "close_instruction_screen" in f.commands and f.brake == 1.0 and f.keys == ("KEY_SPACE",)


def test_keyboard_driving_and_edges() -> None:
    kb = KeyboardSource()
    assert kb.poll(0.0) == InputFrame()  # nothing held: no opinion (a wheel may drive)
    kb.handle_key("KEY_UP", True)
    kb.handle_key("KEY_LEFT", True)
    kb.handle_key("KEY_LEFT", True)  # auto-repeat is not a second press
    f = kb.poll(0.0)
    assert (f.accelerator, f.steering, f.reverse) == (1.0, pytest.approx(0.3), False)
    assert f.keys == ("KEY_UP", "KEY_LEFT")
    f = kb.poll(0.1)
    assert f.keys == () and f.steering == pytest.approx(0.3)  # held, no new press
    kb.handle_key("KEY_LEFT", False)
    kb.handle_key("KEY_J", True)  # turn_left toggles the signal
    kb.handle_key("KEY_PGUP", True)
    kb.handle_key("KEY_X", True)
    kb.handle_key("KEY_P", True)
    kb.handle_key("KEY_3", True)
    f = kb.poll(0.2)
    assert f.steering is None and f.turn_signal == "left" and f.shift_up and f.toggle_cruise
    assert f.commands == ("toggle_pause", "reset_car_pos3")
    kb.handle_key("KEY_J", False)
    kb.handle_key("KEY_J", True)
    assert kb.poll(0.3).turn_signal == "off"


def test_pygame_key_events_map_to_jme_names() -> None:
    pygame = pytest.importorskip("pygame")
    kb = KeyboardSource()
    for key in (pygame.K_PAGEUP, pygame.K_RETURN, pygame.K_g):
        kb.handle_event(pygame.event.Event(pygame.KEYDOWN, key=key))
    assert kb.poll(0.0).keys == ("KEY_PGUP", "KEY_RETURN", "KEY_G")


def test_merge_later_sources_override_levels_and_events_add_up() -> None:
    wheel = InputFrame(steering=-0.5, accelerator=0.4, buttons=(1,), keys=("JOY_1",))
    keys = InputFrame(steering=0.3, keys=("KEY_G",))
    m = merge_frames([wheel, keys])
    assert (m.steering, m.accelerator, m.buttons, m.keys) == (0.3, 0.4, (1,), ("JOY_1", "KEY_G"))


# ---------------------------------------------------------------------- joystick
def g27() -> FakeJoystick:
    return FakeJoystick("Fake G27", axes=8, buttons=20)


def test_axis_mapping_inversion_sensitivity_from_settings(corpus: Path) -> None:
    settings = load_task(corpus / "opends-cts/ReactionTest").settings  # G27: steering 3, accel 6/brake 5/clutch 7 inverted
    axes = axis_maps_from_settings(settings)
    assert axes["steering"] == AxisMap(0, 3, False, 1.0) and axes["accelerator"] == AxisMap(0, 6, True, 1.0)
    wheel = g27()
    src = JoystickSource(FakeJoystickBackend(wheel), axes)
    wheel.axes[3] = 0.5  # wheel turned right
    wheel.axes[6] = -1.0  # inverted: -1 raw = +1 = fully pressed with the default range -1..1
    wheel.axes[5] = 1.0  # inverted: released
    wheel.axes[7] = 0.0  # clutch half way
    f = src.poll(0.0)
    assert f.steering == pytest.approx(-0.5)  # right is negative in OpenDS
    assert f.accelerator == pytest.approx(1.0) and f.brake == pytest.approx(0.0) and f.clutch == pytest.approx(0.5)
    sens = JoystickSource(FakeJoystickBackend(wheel), {**axes, "steering": AxisMap(0, 3, True, 1.5)})
    assert sens.poll(0.0).steering == pytest.approx(0.75)  # inverted and 1.5x


def test_calibration_dead_zones_and_pedal_ranges() -> None:
    cal = Calibration(steering=AxisCalibration(dead_zone=0.1), brake=AxisCalibration(dead_zone=0.05, released_raw=0.8, pressed_raw=-0.6))
    wheel = FakeJoystick(axes=4)
    src = JoystickSource(FakeJoystickBackend(wheel), {"steering": AxisMap(0, 0), "brake": AxisMap(0, 1)}, cal)
    wheel.axes[0] = 0.05  # inside the dead zone
    wheel.axes[1] = 0.8  # pedal at rest
    f = src.poll(0.0)
    assert f.steering == 0.0 and f.brake == 0.0
    wheel.axes[0] = -0.55  # left: (0.55 - 0.1) / 0.9 = 0.5
    wheel.axes[1] = -0.6  # fully pressed
    f = src.poll(0.1)
    assert f.steering == pytest.approx(0.5) and f.brake == pytest.approx(1.0)
    wheel.axes[1] = 0.1  # half way
    assert src.poll(0.2).brake == pytest.approx((0.5 - 0.05) / 0.95)


def test_combined_pedals_split_into_throttle_and_brake() -> None:
    wheel = FakeJoystick(axes=2)
    src = JoystickSource(FakeJoystickBackend(wheel))  # defaults: steering axis 0, combined pedals axis 1
    wheel.axes[1] = 0.6
    f = src.poll(0.0)
    assert (f.accelerator, f.brake) == (pytest.approx(0.6), 0.0)
    wheel.axes[1] = -0.3
    f = src.poll(0.1)
    assert (f.accelerator, f.brake) == (0.0, pytest.approx(0.3))


def test_buttons_feed_triggers_timers_and_functions() -> None:
    wheel = g27()
    src = JoystickSource(FakeJoystickBackend(wheel), assignments=[KeyAssignment("close_instruction_screen", "BUTTON_15")])
    wheel.buttons[3] = True
    wheel.buttons[15] = True
    wheel.buttons[9] = True  # default: gear2
    f = src.poll(0.0)
    assert f.buttons == (3, 9, 15) and f.keys == ("JOY_3", "JOY_9", "JOY_15")
    assert f.commands == ("close_instruction_screen",) and f.gear == 2
    assert src.poll(0.1).buttons == ()  # still held: no new press


def test_unplugging_blocks_and_replugging_resumes() -> None:
    wheel = FakeJoystick(axes=2)
    backend = FakeJoystickBackend(wheel)
    src = JoystickSource(backend)
    wheel.axes[0] = -1.0
    assert src.poll(0.0).steering == pytest.approx(1.0) and not src.status().blocking
    wheel.attached = False  # reads now raise, as pygame's do after JOYDEVICEREMOVED
    assert src.poll(0.1).steering is None
    st = src.status()
    assert st.blocking and not st.connected and "disconnected" in st.message and "Fake Wheel" in st.message
    wheel.attached = True
    assert src.poll(0.5).steering == pytest.approx(1.0)
    assert not src.status().blocking


def test_calibration_files(tmp_path: Path) -> None:
    cal = load_calibration(ROOT / "configs" / "wheel_calibration.yaml")
    assert cal.brake.released_raw == 1.0 and cal.steering.dead_zone == pytest.approx(0.01)
    good = tmp_path / "rig.json"
    good.write_text(json.dumps({"clutch": {"dead_zone": 0.2}}))
    assert load_calibration(good).clutch.dead_zone == 0.2
    bad = tmp_path / "typo.yaml"
    bad.write_text("brake:\n  dead_zon: 0.1\n")
    with pytest.raises(ValueError, match=r"typo\.yaml.*dead_zon"):
        load_calibration(bad)
    with pytest.raises(ValueError, match="dead_zone"):
        AxisCalibration(dead_zone=1.5)


# ---------------------------------------------------------------------- in a session
class FlakyBackend(FakeJoystickBackend):
    """Unplugs the wheel after `unplug_after` reads; plugs it back after `replug_after` scans."""

    def __init__(self, wheel: FakeJoystick, unplug_after: int, replug_after: int) -> None:
        super().__init__(wheel)
        self.wheel = wheel
        self.scans_while_gone = 0
        self.replug_after = replug_after
        original = wheel.get_axis
        self.reads = 0

        def get_axis(axis: int) -> float:
            self.reads += 1
            if self.reads == unplug_after:
                wheel.attached = False
            return original(axis)

        wheel.get_axis = get_axis  # type: ignore[method-assign]

    def devices(self):  # type: ignore[no-untyped-def]
        if not self.wheel.attached:
            self.scans_while_gone += 1
            if self.scans_while_gone >= self.replug_after:
                self.wheel.attached = True
        return super().devices()


def test_session_with_wheel_keys_and_unplug(task_copy) -> None:  # type: ignore[no-untyped-def]
    folder = reaction_test_with_extra_triggers(task_copy)
    wheel = FakeJoystick(axes=8, buttons=8)  # the task's settings.xml maps a G27: steering 3, pedals 5-7 inverted
    wheel.axes[5] = wheel.axes[7] = 1.0  # brake and clutch released
    wheel.axes[6] = -1.0  # throttle floored
    backend = FlakyBackend(wheel, unplug_after=400, replug_after=3)
    cfg = DriveConfig(target=str(folder), inputs=(InputSpec("joystick"), InputSpec("keyboard")), window=False, fast=True, duration_s=6.0)
    with DriveSession(cfg, joystick_backend=backend) as s:
        s.sources.keyboard.handle_key("KEY_G", True)  # report_reaction: the pressKey:KEY_G trigger
        wheel.buttons[3] = True  # the pressButton:3 trigger
        result = s.run()
        events = [(e.kind, e.source) for e in s.world.events]
    assert result.end_reason == "time limit" and result.sim_time_s == pytest.approx(6.0)
    assert ("trigger", "ReportKeyTrigger") in events and ("trigger", "WheelButtonTrigger") in events
    assert any("disconnected" in reason for _, reason in result.holds), result.holds
    assert result.metrics["mean_speed_kmh"] > 20.0  # the wheel's throttle drove the car


# ---------------------------------------------------------------------- toggles become explicit controls
def test_controls_builder_resolves_toggles_against_the_car() -> None:
    from opends_gym.human.controls_builder import ControlsBuilder
    from opends_gym.sim.world import World

    world = World("ReactionTest")
    b = ControlsBuilder(world)
    c = b.build(InputFrame(accelerator=1.0, reverse=True))  # standing still: reverse is engaged
    assert c.gear == -1 and c.accelerator == 1.0
    world.ego.state.u = 10.0
    c = b.build(InputFrame(accelerator=1.0, reverse=True))  # rolling forward: the reverse pedal brakes first
    assert c.gear is None and c.brake == 1.0 and c.accelerator == 0.0
    c = b.build(InputFrame(toggle_cruise=True, toggle_engine=True, automatic=False, toggle_hand_brake=True))
    assert c.cruise_control is (not world.ego.cruise_active) and c.engine_on is False
    assert c.toggle_automatic is True and c.hand_brake is True  # automatic=False on an automatic gearbox: switch
    assert b.build(InputFrame()).hand_brake is True  # the hand brake stays on until toggled again
    first = b.build(InputFrame(commands=("reset_car",))).reset_to
    assert first == b.reset_ids[0] and b.build(InputFrame(commands=("reset_car_pos1",))).reset_to == b.reset_ids[0]
    assert b.build(InputFrame(commands=("reset_car_pos9",))).reset_to is None  # the task has fewer reset points
    world.close()


class TimedWheel(FakeJoystick):
    """Presses button 3 on the `press_at`-th poll (get_numbuttons is read once per poll)."""

    def __init__(self, press_at: int) -> None:
        super().__init__(axes=8, buttons=8)
        self.axes[5] = self.axes[7] = 1.0
        self.polls = 0
        self.press_at = press_at

    def get_numbuttons(self) -> int:
        self.polls += 1
        self.buttons[3] = self.polls >= self.press_at
        return super().get_numbuttons()


def test_wheel_button_answers_a_key_reaction_timer(task_copy) -> None:  # type: ignore[no-untyped-def]
    folder = reaction_test_with_extra_triggers(task_copy)
    wheel = TimedWheel(press_at=90)  # 1.5 s after the timer is armed
    cfg = DriveConfig(target=str(folder), inputs=(InputSpec("joystick"), InputSpec("keyboard")), window=False, fast=True, duration_s=3.0)
    with DriveSession(cfg, joystick_backend=FakeJoystickBackend(wheel)) as s:
        s.sources.keyboard.handle_key("KEY_L", True)  # arms the key reaction timer at the first step
        result = s.run()
    assert [(r["group"], r["result"]) for r in result.reactions] == [("WheelButton", 1)]
    assert 1.4 < result.reactions[0]["reaction_time_s"] < 1.55  # armed at the first step, pressed ~1.5 s later
