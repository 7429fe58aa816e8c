"""CAN input: OpenDS's gateway protocol (parsing, hostile input, reconnects, a loopback
drive through the ReactionTest) and a python-can bus decoded with the example DBC."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import can
import cantools
import pytest

from opends_gym.human.inputs.base import InputFrame
from opends_gym.human.inputs.can_bus import CanBusSource
from opends_gym.human.inputs.can_gateway import CanGatewaySource
from opends_gym.human.inputs.can_protocol import GatewayFramer, parse_chunk
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig, parse_input_spec
from opends_gym.human.snapshot import VehicleSnapshot
from tests.human_helpers import Lockstep, ReactionTestDriver, ScriptedGateway, wait_for

ROOT = Path(__file__).resolve().parent.parent
DBC = ROOT / "configs" / "can_example.dbc"


def msg(*actions: tuple[str, str]) -> str:
    return "<message>" + "".join(f'<action name="{n}">{v}</action>' for n, v in actions) + "</message>"


# ---------------------------------------------------------------------- protocol
def test_actions_mean_what_they_mean_in_opends() -> None:
    u, problems = parse_chunk(msg(("steering", "-92"), ("acceleration", "0.1"), ("brake", "0.3")), 270.0)
    assert problems == []
    assert u.steering == pytest.approx(92 / 270)  # steer = -clamp(deg / maxSteeringAngle)
    assert u.accelerator == pytest.approx(0.6) and u.brake == pytest.approx(0.3)  # acceleration x 6
    u, _ = parse_chunk(msg(("steering", "0.1"), ("acceleration", "0.5"), ("steering", "400")), 270.0)
    assert u.steering == -1.0 and u.accelerator == 1.0  # clamped; later actions win
    u, _ = parse_chunk(msg(("steering", "0.2")), 270.0)
    assert u.steering == 0.0  # +-0.001 deadband
    u, _ = parse_chunk(msg(("button", "cs"), ("button", "return"), ("setGear", "-1"), ("automaticTransmission", "false")), 270.0)
    assert u.commands == ["toggle_cam", "reset_car"] and u.gear == -1 and u.automatic is False
    u, _ = parse_chunk('<message><action name="display" duration="3">Bitte bremsen</action></message>', 270.0)
    assert u.messages == [("Bitte bremsen", 3.0)]
    u, _ = parse_chunk(msg(("KL54_RM_State", "1"), ("MFLplus_State", "1")), 270.0)
    assert u.brake == 1.0 and u.accelerator == 1.0
    u, _ = parse_chunk(msg(("channel0", "2.52"), ("channel1", "5.0"), ("channel2", "1.0")), 270.0)
    assert u.steering == pytest.approx(0.0, abs=1e-9) and u.accelerator == 1.0 and u.brake == 0.0


@pytest.mark.parametrize(
    "text",
    [
        msg(("steering", "nan")),
        msg(("steering", "1e9")),
        msg(("brake", "1.7")),
        msg(("acceleration", "-0.2")),
        msg(("setGear", "12")),
        msg(("button", "eject")),
        msg(("warpDrive", "1")),
        msg(("automaticTransmission", "maybe")),
    ],
)
def test_out_of_range_or_unknown_actions_are_reported_and_ignored(text: str) -> None:
    u, problems = parse_chunk(text, 270.0)
    assert len(problems) == 1
    assert (u.steering, u.accelerator, u.brake, u.gear, u.automatic, u.commands) == (None, None, None, None, None, [])


def test_framing_reassembles_split_messages_and_bounds_garbage() -> None:
    fr = GatewayFramer()
    whole = msg(("steering", "27"))
    assert fr.feed(whole[:15].encode()) == []
    assert fr.feed((whole[15:] + "\0\0").encode()) == [whole]  # NULs stripped, as OpenDS
    assert fr.feed(b"x" * 20000) == [] and fr.buffer == "" and fr.dropped == 1  # no end tag: dropped
    huge = "<message>" + '<action name="display">' + "a" * 12000 + "</action></message>"
    assert fr.feed(huge.encode()) == [] and fr.dropped == 2
    # a half message followed by a whole one: the whole one survives
    u, problems = parse_chunk('<message><action name="steer' + msg(("brake", "0.5")), 270.0)
    assert u.brake == 0.5 and problems
    u, problems = parse_chunk("<<<garbage>>></message>", 270.0)
    assert problems and u.brake is None


def test_entities_are_not_expanded() -> None:
    bomb = '<!DOCTYPE m [<!ENTITY a "1"><!ENTITY b "&a;&a;&a;&a;">]>' + msg(("brake", "&b;"))
    u, problems = parse_chunk(bomb, 270.0)
    assert u.brake is None and problems


# ---------------------------------------------------------------------- the TCP client
def test_gateway_survives_hostile_input_and_reconnects() -> None:
    """Each wait is for the event itself, never for time to pass: the source is started after
    its not-yet-connected status is read (it connects within microseconds on a fast host),
    and the I/O thread's parsing is awaited through a last message whose effect shows it got
    that far (the thread handles the stream in order; counts of problems or queued updates
    depend on how the stream is cut into reads)."""
    gw = ScriptedGateway()
    src = CanGatewaySource("127.0.0.1", gw.port, max_steering_deg=270.0, start=False)
    try:
        assert src.status().blocking  # the drive waits for the gateway's first connection
        src.client.start()
        wait_for(lambda: src.client.connected)
        gw.send(b"\x00\xff garbage <<< \xfe")
        gw.send(b"y" * 15000)
        gw.send(("<message>" + '<action name="display">' + "z" * 11000 + "</action></message>").encode())
        gw.send(b'<message><action name="steering">-5')  # half a message...
        gw.send(b"4</action></message>")  # ...completed later
        gw.send(msg(("brake", "2.5")).encode())
        gw.send(msg(("setGear", "3")).encode())  # (the last: once it is applied, so is everything before it)
        f = poll_until(src, lambda f: f.gear == 3)
        assert f.steering == pytest.approx(54 / 270) and f.brake is None
        assert src.problems >= 3  # the unterminated and the oversized input, the brake out of range
        gw.drop()  # the gateway goes away abruptly
        wait_for(lambda: gw.connections == 2 and src.client.connected, 10.0)
        st = src.status()
        assert st.connected and not st.blocking
        gw.send(msg(("acceleration", "0.1")).encode())
        f = poll_until(src, lambda f: f.accelerator is not None, t_s=1.0)
        assert f.accelerator == pytest.approx(0.6) and f.steering == pytest.approx(54 / 270)  # levels are held
        src.feedback(VehicleSnapshot(t_s=1.0, speed_kmh=42.0, yaw_rad=0.0, x_m=1.5, z_m=-3.0))
        wait_for(lambda: b"$SimCarState#42.00#0.00#1.500#-3.000%" in gw.received)
    finally:
        src.close()
        said_goodbye = gw.wait_received(b"exit")  # (before the gateway stops reading)
        gw.close()
    assert said_goodbye  # OpenDS says goodbye


def poll_until(src: CanGatewaySource, done: Callable[[InputFrame], bool], t_s: float = 0.0) -> InputFrame:
    """Poll the source as the simulation does, each step, until a frame shows `done`; that frame."""
    frames: list[InputFrame] = []
    wait_for(lambda: done(frames.append(src.poll(t_s)) or frames[-1]))
    return frames[-1]


def test_gateway_loopback_drives_the_reaction_test() -> None:
    """The test plays the gateway: from the feedback channel it steers, brakes and accelerates."""
    gw = ScriptedGateway(ReactionTestDriver())
    spec = parse_input_spec(f"can-tcp:127.0.0.1:{gw.port}")
    cfg = DriveConfig(target="ReactionTest", inputs=(spec,), window=False, fast=True, duration_s=48.0)
    try:
        with DriveSession(cfg) as session:
            gateway_source = next(s for s in session.sources.combiner.sources if s.name == "can-gateway")
            step = Lockstep(gateway_source, gw)  # (the gateway answers before the next physics step)
            result = session.run()
    finally:
        gw.close()
    assert step.stalls == 0 and step.sent >= 0.9 * 48 * 20
    table = [(r["group"], r["result"]) for r in result.reactions]
    assert table == [("Brake", 1), ("LaneChange", 1)], result.reactions
    assert 0.0 < result.reactions[0]["reaction_time_s"] < 3.0
    assert result.metrics["Brake_correct"] == 1.0 and result.metrics["LaneChange_correct"] == 1.0
    assert len(gw.feedback) >= 0.9 * 48 * 20  # feedback at updateRate (20 Hz)


# ---------------------------------------------------------------------- python-can + DBC
@pytest.fixture
def bus_pair():  # type: ignore[no-untyped-def]
    channel = f"opends-test-{time.monotonic_ns()}"
    src = CanBusSource("virtual", channel, dbc=DBC, max_steering_deg=450.0)
    peer = can.Bus(interface="virtual", channel=channel)
    wait_for(lambda: src.connected)
    yield src, peer, cantools.database.load_file(str(DBC))
    src.close()
    peer.shutdown()


def send(peer, db, name: str, **signals) -> None:  # type: ignore[no-untyped-def]
    m = db.get_message_by_name(name)
    full = {s.name: 0 for s in m.signals}
    full.update(signals)
    peer.send(can.Message(arbitration_id=m.frame_id, data=m.encode(full, strict=False), is_extended_id=False))


def test_can_bus_signals_drive_and_feedback_frames_return(bus_pair) -> None:  # type: ignore[no-untyped-def]
    src, peer, db = bus_pair
    send(peer, db, "DriverInputs", SteeringWheelAngle=-90.0, AcceleratorPedal=50.0, BrakePedal=0.0, Gear=2)
    send(peer, db, "DriverButtons", ReactionButton=1, TurnSignal=1, ShiftUp=1)
    wait_for(lambda: src.frames >= 2)
    f = src.poll(0.0)
    assert f.steering == pytest.approx(0.2) and f.accelerator == pytest.approx(0.5) and f.gear == 2
    assert f.buttons == (0,) and f.keys == ("JOY_0",) and f.turn_signal == "left" and f.shift_up
    send(peer, db, "DriverButtons", ReactionButton=1, TurnSignal=1)
    wait_for(lambda: src.frames >= 3)
    f = src.poll(0.1)
    assert f.buttons == () and f.turn_signal is None and f.gear is None  # held, not pressed again
    src.feedback(VehicleSnapshot(t_s=1.0, speed_kmh=57.25, yaw_rad=0.0, gear=3, rpm=2100.0, x_m=12.5, z_m=-400.25))
    got = {}
    for _ in range(2):
        m = peer.recv(1.0)
        if m is not None:
            got[m.arbitration_id] = db.decode_message(m.arbitration_id, m.data)
    assert got[0x200]["VehicleSpeed"] == pytest.approx(57.25) and got[0x200]["CurrentGear"] == 3
    assert got[0x201]["PositionX"] == pytest.approx(12.5) and got[0x201]["PositionZ"] == pytest.approx(-400.25)


def test_can_bus_bad_frames_are_ignored(bus_pair) -> None:  # type: ignore[no-untyped-def]
    src, peer, db = bus_pair
    peer.send(can.Message(arbitration_id=0x7FF, data=b"\x01\x02", is_extended_id=False))  # not in the DBC
    peer.send(can.Message(arbitration_id=0x100, data=b"\x01", is_extended_id=False))  # too short to decode
    send(peer, db, "DriverInputs", SteeringWheelAngle=10.0, AcceleratorPedal=120.0)  # pedal beyond its DBC range
    wait_for(lambda: src.frames >= 1)  # the last frame decoded (without its pedal) and queued: the bad ones came before it
    assert src.problems >= 2
    f = src.poll(0.0)
    assert f.accelerator is None and f.steering == pytest.approx(-10.0 / 450.0)
    assert src.status().connected


def test_can_bus_session_moves_the_car() -> None:
    channel = f"opends-session-{time.monotonic_ns()}"
    peer = can.Bus(interface="virtual", channel=channel)
    db = cantools.database.load_file(str(DBC))
    spec = parse_input_spec(f"can-bus:virtual:{channel}")
    cfg = DriveConfig(target="ReactionTest", inputs=(spec,), window=False, fast=True, duration_s=4.0)
    try:
        with DriveSession(cfg) as session:
            bus = session.sources.combiner.sources[0]
            wait_for(lambda: bus.connected)
            send(peer, db, "DriverInputs", AcceleratorPedal=100.0)
            wait_for(lambda: bus.frames >= 1)  # (received before the drive starts: --fast runs 4 s in a blink)
            result = session.run()
            final_speed = session.snapshot.speed_kmh
        feedback = [m for m in iter(lambda: peer.recv(0.2), None) if m.arbitration_id == 0x200]
    finally:
        peer.shutdown()
    assert result.end_reason == "time limit"
    assert final_speed > 40.0, final_speed  # full throttle; the engine's minSpeed alone holds about 20 km/h
    assert len(feedback) >= 0.9 * 4 * 20
