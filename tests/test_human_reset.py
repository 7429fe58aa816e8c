"""A human session goes on: on the Lane Change Test the car leaves the road three times and
is put back on its lane by OpenDS's reset key (R), a CAN frame and the settings server;
the session runs to its duration and the recording marks each reset and replays exactly."""

from __future__ import annotations

import time
from pathlib import Path

import can
import cantools

from opends_gym.human.inputs.base import InputFrame, InputStatus
from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig, InputSpec, parse_input_spec
from opends_gym.record import read_recording
from opends_gym.record.replay import replay
from tests.human_helpers import wait_for
from tests.test_human_settings_server import Client

ROOT = Path(__file__).resolve().parent.parent
DBC = ROOT / "configs" / "can_example.dbc"
OFF_ROAD = ((0.5, 2.0), (6.0, 7.5), (11.5, 13.0))  # (from, to) simulated s: steer left until off the road
RESETS_AT = (3.0, 8.5, 14.0)  # key, CAN, settings server


class Steerer:
    """Full speed ahead; steers left in the `OFF_ROAD` windows; at `RESETS_AT` calls the
    experimenter's action (once each, from inside the loop, so the timing is exact)."""

    name = "script"

    def __init__(self, actions: list) -> None:  # type: ignore[type-arg]
        self.actions = list(zip(RESETS_AT, actions))

    def poll(self, t_s: float) -> InputFrame:
        while self.actions and t_s >= self.actions[0][0]:
            self.actions.pop(0)[1]()
        steer = 0.3 if any(a <= t_s < b for a, b in OFF_ROAD) else 0.0
        return InputFrame(steering=steer, accelerator=1.0)

    def status(self) -> InputStatus:
        return InputStatus(self.name)

    def close(self) -> None:
        pass


def test_a_session_survives_leaving_the_road_and_three_kinds_of_reset(tmp_path: Path) -> None:
    rec = tmp_path / "lct.mcap"
    channel = f"opends-reset-{time.monotonic_ns()}"
    peer = can.Bus(interface="virtual", channel=channel)
    db = cantools.database.load_file(str(DBC))
    cfg = DriveConfig(
        target="LaneChangeTest",
        inputs=(InputSpec("keyboard"), parse_input_spec(f"can-bus:virtual:{channel}")),
        window=False,
        fast=True,
        duration_s=17.0,
        record_path=str(rec),
        settings_server=True,
        server_port=0,
    )
    try:
        with DriveSession(cfg) as session:
            kb = session.sources.keyboard
            bus = next(s for s in session.sources.combiner.sources if s.name == "can-bus")
            port = session.sources.server.address[1]
            positions: list[tuple[float, float]] = []  # (lateral offset m, speed km/h) right after each reset

            def key_r() -> None:  # OpenDS's RESET_CAR key; the LCT has no reset points: the last lane position
                kb.handle_key("KEY_R", True)
                kb.handle_key("KEY_R", False)

            def can_frame() -> None:
                m = db.get_message_by_name("SessionCommands")
                frames = bus.frames
                peer.send(can.Message(arbitration_id=m.frame_id, data=m.encode({"ResetPosition": 1}), is_extended_id=False))
                wait_for(lambda: bus.frames > frames)

            def settings_server() -> None:
                c = Client(port)
                c.send(("ResetPosition", ""))
                assert c.reply().find("Event[@Name='PositionReset']") is not None
                c.close()

            session.sources.combiner.sources.insert(0, Steerer([key_r, can_frame, settings_server]))
            seen = 0

            def watch(world, _c) -> None:  # type: ignore[no-untyped-def]
                nonlocal seen
                if session.base.resets > seen:
                    seen = session.base.resets
                    s = world.ego.state
                    positions.append((session.base.guide.lane_position(s.x, s.z)[3], s.u * 3.6))

            session.world.observers.append(watch)
            result = session.run()
    finally:
        peer.shutdown()
    # the drive went on off the road and after each reset, to its duration
    assert result.end_reason == "time limit" and result.sim_time_s >= 17.0 - 1e-9  # (--duration is the env's time limit)
    assert result.metrics["road_exits"] == 3 and result.metrics["resets"] == 3 and result.metrics["off_road_s"] > 1.0
    assert len(positions) == 3 and all(abs(off) < 0.05 and v < 0.5 for off, v in positions)  # in the lane, at rest
    # the recording marks each reset (an /events entry and the action it came with) and replays exactly
    recording = read_recording(rec)
    marks = [e for e in recording.topic("/events") if e["kind"] == "reset"]
    assert [m["source"] for m in marks] == ["last_lane_position"] * 3
    assert [round(m["t_s"]) for m in marks] == [round(t) for t in RESETS_AT]
    assert sum(1 for a in recording.topic("/actions") if a.get("reset_position")) == 3
    check = replay(rec)
    assert check.ok, check.mismatch
    check.close()


def test_the_can_gateway_and_its_button_action_reset_too() -> None:
    """OpenDS's gateway protocol: `button` `return` is RESET_CAR (the last lane position on a
    task without reset points), `resetPosition` always the last lane position."""
    from opends_gym.human.inputs.can_protocol import parse_chunk

    u, problems = parse_chunk('<message><action name="button">resetPosition</action><action name="button">return</action></message>', 270.0)
    assert problems == [] and u.commands == ["reset_position", "reset_car"]
