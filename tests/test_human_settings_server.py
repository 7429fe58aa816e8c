"""The settings-controller server: OpenDS's XML events, pushes, vehicle control and remote
triggers, against a real TCP client; and in a running session."""

from __future__ import annotations

import socket
import threading
import time

import pytest
from lxml import etree

from opends_gym.human.runner import DriveSession
from opends_gym.human.session_config import DriveConfig, InputSpec
from opends_gym.human.settings_server import SettingsControllerServer
from opends_gym.human.snapshot import VehicleSnapshot
from tests.human_helpers import reaction_test_with_extra_triggers

SPEED = "/root/thisVehicle/physicalAttributes/speed"


class Client:
    """A settings-controller client: sends `<Message>`s, collects whole replies."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        self.buf = b""

    def send(self, *events: tuple[str, str]) -> None:
        body = "".join(f'<Event Name="{n}">{v}</Event>' for n, v in events)
        self.sock.sendall(f"<Message>{body}</Message>".encode())

    def raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def reply(self, timeout_s: float = 5.0) -> etree._Element:
        end = time.monotonic() + timeout_s
        while b"</Message>" not in self.buf:
            if time.monotonic() > end:
                raise AssertionError(f"no reply; got {self.buf[:200]!r}")
            self.buf += self.sock.recv(65536)
        i = self.buf.index(b"</Message>") + len(b"</Message>")
        chunk, self.buf = self.buf[:i], self.buf[i:]
        return etree.fromstring(chunk[chunk.index(b"<Message") :])

    def reply_named(self, name: str, timeout_s: float = 5.0) -> etree._Element:
        """The next reply holding an event `name` (pushes in between are skipped)."""
        end = time.monotonic() + timeout_s
        while True:
            r = self.reply(max(0.1, end - time.monotonic()))
            ev = r.find(f"Event[@Name='{name}']")
            if ev is not None:
                return ev

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def server():  # type: ignore[no-untyped-def]
    srv = SettingsControllerServer("127.0.0.1", 0, remote_ids={"honk", "resume"}).start()
    srv.publish(VehicleSnapshot(t_s=3.0, speed_kmh=48.5, gear=3, rpm=2400.0, accelerator=0.4, x_m=1.0, z_m=-20.0))
    yield srv
    srv.close()


def test_binds_to_localhost_by_default() -> None:
    srv = SettingsControllerServer(port=0).start()
    try:
        assert srv.address[0] == "127.0.0.1"
    finally:
        srv.close()


def test_subscribe_push_and_get_value(server) -> None:  # type: ignore[no-untyped-def]
    c = Client(server.address[1])
    try:
        c.send(("EstablishConnection", "50"), ("Subscribe", SPEED), ("Subscribe", "/root/thisVehicle/exterior/gearUnit/currentGear"))
        r = c.reply()
        names = [e.get("Name") for e in r.iter("Event")]
        assert names == ["ConnectionEstablished", "Subscriptions", "Subscriptions"]
        assert r.findall("Event")[2].find("root/thisVehicle/exterior/gearUnit/currentGear") is not None
        push = c.reply_named("SubscribedValues")
        assert float(push.findtext("root/thisVehicle/physicalAttributes/speed")) == pytest.approx(48.5)
        assert push.findtext("root/thisVehicle/exterior/gearUnit/currentGear") == "3"
        server.publish(VehicleSnapshot(t_s=3.1, speed_kmh=51.0))
        for _ in range(5):  # pushes follow the latest snapshot
            push = c.reply_named("SubscribedValues")
            if float(push.findtext("root/thisVehicle/physicalAttributes/speed")) == pytest.approx(51.0):
                break
        else:
            raise AssertionError("pushes never showed the new speed")
        c.send(("GetValue", "/root/thisVehicle/physicalAttributes/Properties/speed"))  # OpenDS 4.x path form
        ev = c.reply_named(SPEED.replace("speed", "Properties/speed"))
        assert ev.findtext("root/thisVehicle/physicalAttributes/speed") is not None
        c.send(("SetUpdateInterval", "200"), ("GetUpdateInterval", ""), ("Unsubscribe", "/root/thisVehicle"))
        ev = c.reply_named("UpdateInterval")
        assert ev.text.strip() == "200"
        c.send(("GetSubscriptions", ""))
        ev = c.reply_named("Subscriptions")
        assert len(ev.find("root")) == 0
        c.send(("GetDataSchema", ""))
        assert c.reply_named("DataSchema").find("root/thisVehicle/physicalAttributes/speed") is not None
    finally:
        c.close()


def test_vehicle_control_and_remote_triggers(server) -> None:  # type: ignore[no-untyped-def]
    c = Client(server.address[1])
    try:
        c.send(("SetVehicleControl", "drivingCar;0.25;0.8;0"), ("SetVehicleControl", "car7;-0.1;0.3;0.2"))
        r = c.reply()
        assert [e.get("Name") for e in r.iter("Event")] == ["UpdateVehicleControl", "UpdateVehicleControl"]
        request = "<liveDataRequest><triggerExecution><triggerId>honk</triggerId></triggerExecution>" + (
            "<triggerExecution><triggerId>nope</triggerId></triggerExecution></liveDataRequest>"
        )
        c.raw(f'<Message><Event Name="GetXMLRequest">{request}</Event></Message>'.encode())
        ev = c.reply_named("XMLRequest")
        status = {t.findtext("triggerId"): t.findtext("status") for t in ev.iter("triggerExecution")}
        assert status == {"honk": "success", "nope": "trigger ID does not exist"}
        f = server.poll(0.0)
        assert (f.steering, f.accelerator, f.brake) == (0.25, 0.8, 0.0)
        assert f.remote_triggers == ("honk",)
        assert [(t.vehicle_id, t.steering, t.accelerator, t.brake) for t in f.traffic_controls] == [("car7", -0.1, 0.3, 0.2)]
        f = server.poll(0.1)
        assert f.steering == 0.25 and f.remote_triggers == () and f.traffic_controls == ()  # ego control is held
    finally:
        c.close()


def test_bad_requests_get_errors_and_the_connection_lives(server) -> None:  # type: ignore[no-untyped-def]
    c = Client(server.address[1])
    try:
        c.raw(b"<Message><Event Name='GetValue'>unclosed</Message>")
        assert c.reply().findtext("Error") == "No valid XML data received"
        c.send(("SetVehicleControl", "drivingCar;abc;1;0"), ("SetVehicleControl", "drivingCar;0;7;0"), ("Teleport", "x"))
        errors = [e.text for e in c.reply().iter("Event") if e.get("Name") == "Error"]
        assert len(errors) == 3 and "unknown event" in errors[2]
        c.raw(b"<Message>" + b"x" * 70000)  # oversized, never closed
        assert c.reply().findtext("Error") == "request too large"
        bomb = b'<!DOCTYPE M [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]><Message><Event Name="Subscribe">&b;</Event></Message>'
        c.raw(bomb)
        r = c.reply()
        assert r.find("Event[@Name='Error']") is not None or r.findtext("Error")
        c.send(("GetValue", SPEED))
        assert float(c.reply_named(SPEED).findtext("root/thisVehicle/physicalAttributes/speed")) == pytest.approx(48.5)
        assert server.poll(0.0).steering is None  # nothing invalid reached the car
    finally:
        c.close()


def test_session_answers_subscriptions_and_obeys_vehicle_control(task_copy) -> None:  # type: ignore[no-untyped-def]
    folder = reaction_test_with_extra_triggers(task_copy)
    cfg = DriveConfig(
        target=str(folder), inputs=(InputSpec("keyboard"),), window=False, settings_server=True, server_port=0, duration_s=2.0
    )
    pushes: list[float] = []
    replies: dict[str, str] = {}

    with DriveSession(cfg) as session:
        port = session.sources.server.address[1]

        def experimenter() -> None:
            c = Client(port)
            c.send(("EstablishConnection", "100"), ("Subscribe", SPEED), ("SetVehicleControl", "drivingCar;0.05;1;0"))
            c.reply()
            c.raw(
                b'<Message><Event Name="GetXMLRequest"><liveDataRequest><triggerExecution><triggerId>honk</triggerId>'
                b"</triggerExecution></liveDataRequest></Event></Message>"
            )
            replies["honk"] = c.reply_named("XMLRequest").findtext("liveDataRequest/triggerExecution/status") or ""
            end = time.monotonic() + 1.5
            while time.monotonic() < end:
                try:
                    ev = c.reply_named("SubscribedValues", 0.5)
                except AssertionError:
                    break
                pushes.append(float(ev.findtext("root/thisVehicle/physicalAttributes/speed") or "nan"))
            c.close()

        t = threading.Thread(target=experimenter)
        t.start()
        result = session.run()  # real time: 2 simulated seconds take 2 s
        t.join(5.0)
        events = [(e.kind, e.source) for e in session.world.events]
        steering = session.world.ego.inputs.steering
    assert steering == pytest.approx(0.05)  # the experimenter's SetVehicleControl drove the car
    assert replies["honk"] == "success" and ("trigger", "RemoteHonkTrigger") in events
    assert len(pushes) >= 5 and max(pushes) > 15.0 and pushes == sorted(pushes)  # pushes follow the accelerating car
    assert result.wall_s >= 1.9  # paced to the wall clock


def test_traffic_values_come_from_the_traffic_manager(corpus) -> None:  # type: ignore[no-untyped-def]
    from opends_gym.human.snapshot import snapshot_of
    from opends_gym.human.value_tree import build_tree, matching_paths
    from opends_gym.sim.world import World

    world = World(corpus / "opends-cts/Idealtest2")
    try:
        world.run(0.5)
        snap = snapshot_of(world)
    finally:
        world.close()
    ids = [str(i) for i in world.traffic.ids]
    assert ids and [t[0] for t in snap.traffic] == ids
    tree = build_tree(matching_paths("/root/thisVehicle/roadAttributes/traffic"), snap)
    assert tree.findtext("thisVehicle/roadAttributes/traffic/objName") == ",".join(ids)
    assert tree.findtext("thisVehicle/roadAttributes/traffic/numObjs") == str(len(ids))
