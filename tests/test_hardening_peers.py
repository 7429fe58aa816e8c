"""Hostile peers on loopback (issue 21, cases 8 and 9): the settings server caps connections,
closes idle ones, refuses absurd and non-ASCII numbers without losing a thread, and can keep
control commands to allowed peers or token holders; the CAN gateway refuses non-ASCII
numerals; floods of bad messages log a few rate-limited WARNINGs with a suppressed count."""

from __future__ import annotations

import logging
import socket
import threading
import time

import pytest

from opends_gym.human.inputs.can_gateway import CanGatewaySource
from opends_gym.human.inputs.can_protocol import parse_chunk
from opends_gym.human.settings_server import SettingsControllerServer
from opends_gym.human.snapshot import VehicleSnapshot
from opends_gym.human.wire import RateLimitedWarning, ascii_float, ascii_int
from tests.human_helpers import ScriptedGateway, wait_for
from tests.test_human_settings_server import SPEED
from tests.test_human_settings_server import Client as _Client

HOSTILE_NUMERALS = ["١٢", "１０", "1_0", "0x10", "1e308e", " 1 2", "inf", "nan", "٣.٥"]


class Client(_Client):
    def reply_named(self, name: str, timeout_s: float = 5.0):  # type: ignore[no-untyped-def]
        """The next reply holding an event `name`, within `timeout_s` even while pushes arrive."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            ev = self.reply(max(0.1, end - time.monotonic())).find(f"Event[@Name='{name}']")
            if ev is not None:
                return ev
        raise AssertionError(f"no {name} reply within {timeout_s} s")


def _closed_by_server(sock: socket.socket, timeout_s: float = 3.0) -> bytes:
    """Everything the server sent before closing (raises if it stays open)."""
    sock.settimeout(timeout_s)
    got = b""
    while True:
        data = sock.recv(65536)
        if not data:
            return got
        got += data


def _server(**kwargs) -> SettingsControllerServer:  # type: ignore[no-untyped-def]
    srv = SettingsControllerServer("127.0.0.1", 0, remote_ids={"honk"}, **kwargs).start()
    srv.publish(VehicleSnapshot(t_s=1.0, speed_kmh=30.0))
    return srv


@pytest.mark.parametrize("text", HOSTILE_NUMERALS)
def test_only_ascii_decimals_are_numbers(text: str) -> None:
    with pytest.raises(ValueError):
        ascii_float(text) if text not in ("inf", "nan") else ascii_int(text)
    with pytest.raises(ValueError):
        ascii_int(text)
    assert ascii_float(" -92.5 ") == -92.5 and ascii_float("1e-3") == 0.001 and ascii_int("+12") == 12


@pytest.mark.parametrize("text", HOSTILE_NUMERALS)
def test_can_gateway_refuses_non_ascii_numerals(text: str) -> None:
    for name in ("steering", "channel0", "setGear", "brake", "MFLplus_State"):
        u, problems = parse_chunk(f'<message><action name="{name}">{text}</action></message>', 270.0)
        assert len(problems) == 1 and (u.steering, u.accelerator, u.brake, u.gear) == (None, None, None, None)


def test_connection_cap_refuses_extra_clients_without_threads() -> None:
    srv = _server(max_clients=3)
    socks: list[socket.socket] = []
    try:
        threads_before = threading.active_count()
        socks = [socket.create_connection(srv.address, timeout=3.0) for _ in range(3)]
        wait_for(lambda: srv._active == 3)
        for _ in range(20):  # half-open floods beyond the cap are answered and closed
            extra = socket.create_connection(srv.address, timeout=3.0)
            assert b"too many connections" in _closed_by_server(extra)
            extra.close()
        assert srv.refused == 20 and threading.active_count() <= threads_before + 3
        socks[0].close()  # a slot frees when a client leaves
        wait_for(lambda: srv._active == 2)
        c = Client(srv.address[1])
        c.send(("GetValue", SPEED))
        assert float(c.reply_named(SPEED).findtext("root/thisVehicle/physicalAttributes/speed")) == pytest.approx(30.0)
        c.close()
    finally:
        for s in socks:
            s.close()
        srv.close()


def test_idle_and_slow_clients_are_closed_but_subscribers_stay() -> None:
    srv = _server(idle_timeout_s=0.3)
    try:
        silent = socket.create_connection(srv.address, timeout=3.0)
        t0 = time.monotonic()
        assert b"idle for 0.3 s" in _closed_by_server(silent)
        assert time.monotonic() - t0 < 2.0
        loris = socket.create_connection(srv.address, timeout=3.0)
        for ch in b"<Message><Event Name='GetValue'>":  # a byte every 50 ms, never a whole request
            try:
                loris.sendall(bytes([ch]))
            except OSError:
                break
            time.sleep(0.05)
        assert b"idle" in _closed_by_server(loris)
        sub = Client(srv.address[1])
        sub.send(("EstablishConnection", "50"), ("Subscribe", SPEED))
        sub.reply_named("ConnectionEstablished")
        time.sleep(0.6)
        sub.reply_named("SubscribedValues")  # still pushed to after twice the idle timeout
        sub.close()
        wait_for(lambda: srv._active == 0)
    finally:
        srv.close()


@pytest.mark.parametrize("value", ["1e308", "99999999999999999999", "1_0", "１０", "١٢", "5", "-1", "nan"])
def test_absurd_update_intervals_are_refused_and_pushes_go_on(value: str) -> None:
    srv = _server()
    c = Client(srv.address[1])
    try:
        c.send(("EstablishConnection", value))
        assert c.reply_named("Error").text.startswith("EstablishConnection: update interval must be")
        c.send(("EstablishConnection", "20"), ("Subscribe", SPEED))
        c.reply_named("ConnectionEstablished")
        c.send(("SetUpdateInterval", value))
        c.reply_named("Error")
        for _ in range(3):  # the push thread lives
            c.reply_named("SubscribedValues")
        c.send(("SetVehicleControl", f"drivingCar;0;{value};0"))
        c.reply_named("Error")
        assert srv.poll(0.0).steering is None
    finally:
        c.close()
        srv.close()


def test_control_events_need_the_token() -> None:
    srv = _server(control_token="s3cret")
    c = Client(srv.address[1])
    try:
        c.send(("SetVehicleControl", "drivingCar;0.5;1;0"))
        assert "Authenticate" in c.reply_named("Error").text
        c.raw(
            b'<Message><Event Name="GetXMLRequest"><liveDataRequest><triggerExecution><triggerId>honk</triggerId>'
            b"</triggerExecution></liveDataRequest></Event></Message>"
        )
        c.reply_named("Error")
        c.send(("Authenticate", "guess"))
        assert "wrong token" in c.reply_named("Error").text
        f = srv.poll(0.0)
        assert f.steering is None and f.remote_triggers == ()
        c.send(("GetValue", SPEED))  # reading needs no token
        c.reply_named(SPEED)
        c.send(("Authenticate", "s3cret"), ("SetVehicleControl", "drivingCar;0.5;1;0"))
        c.reply_named("UpdateVehicleControl")
        assert srv.poll(0.1).steering == 0.5
        other = Client(srv.address[1])  # the token is per connection
        other.send(("SetVehicleControl", "drivingCar;-0.5;1;0"))
        other.reply_named("Error")
        other.close()
    finally:
        c.close()
        srv.close()


@pytest.mark.parametrize(("peers", "allowed"), [(("10.1.2.3",), False), (("127.0.0.1",), True)])
def test_control_events_only_from_allowed_peers(peers: tuple[str, ...], allowed: bool) -> None:
    srv = _server(control_peers=peers)
    c = Client(srv.address[1])
    try:
        c.send(("SetVehicleControl", "drivingCar;0.25;0;0"))
        r = c.reply()
        names = [e.get("Name") for e in r.iter("Event")]
        assert names == (["UpdateVehicleControl"] if allowed else ["Error"])
        assert srv.poll(0.0).steering == (0.25 if allowed else None)
    finally:
        c.close()
        srv.close()


def test_rate_limited_warning_counts_what_it_held_back(caplog: pytest.LogCaptureFixture) -> None:
    now = [0.0]
    log = logging.getLogger("opends_gym.test.ratelimit")
    warn = RateLimitedWarning(log, interval_s=5.0, clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger=log.name):
        assert warn.warn("bad %s", 1)
        for i in range(999):
            now[0] += 0.001
            assert not warn.warn("bad %s", i)
        now[0] = 5.5
        assert warn.warn("bad %s", "last")
    assert [r.getMessage() for r in caplog.records] == ["bad 1", "bad last (999 similar message(s) suppressed in the last 5 s)"]
    assert warn.total == 1001


def test_floods_of_bad_messages_log_a_few_warnings(caplog: pytest.LogCaptureFixture) -> None:
    gw = ScriptedGateway()
    src = CanGatewaySource("127.0.0.1", gw.port, max_steering_deg=270.0)
    srv = _server()
    c = Client(srv.address[1])
    try:
        with caplog.at_level(logging.WARNING):
            wait_for(lambda: src.client.connected)
            gw.send(('<message><action name="channel0">1_0</action></message>' * 2000).encode())
            wait_for(lambda: src.problems >= 2000)
            for _ in range(300):
                c.send(("SetUpdateInterval", "1e308"))
            for _ in range(300):
                c.reply_named("Error")
        can_lines = [r for r in caplog.records if r.name.startswith("opends_gym.human.inputs")]
        srv_lines = [r for r in caplog.records if r.name == "opends_gym.human.settings_server"]
        assert 1 <= len(can_lines) <= 2 and 1 <= len(srv_lines) <= 2
        assert src.poll(0.0).steering is None  # "1_0" never steered
    finally:
        c.close()
        srv.close()
        src.close()
        gw.close()


def test_can_gateway_bursts_and_endless_messages_stay_bounded(caplog: pytest.LogCaptureFixture) -> None:
    from opends_gym.human.inputs.can_gateway import MAX_PENDING
    from opends_gym.human.inputs.can_protocol import MAX_MESSAGE_CHARS

    gw = ScriptedGateway()
    src = CanGatewaySource("127.0.0.1", gw.port, max_steering_deg=270.0)
    try:
        with caplog.at_level(logging.WARNING):
            wait_for(lambda: src.client.connected)
            gw.send(('<message><action name="brake">0.5</action></message>' * 5000).encode())  # nobody polls
            wait_for(lambda: src.messages_applied + src._updates.qsize() + src.problems >= 5000)
            assert src._updates.qsize() <= MAX_PENDING and src.problems >= 5000 - MAX_PENDING
            while src._updates.qsize():
                src.poll(0.0)
            gw.send(b"<message><action name='display'>")  # a message that never ends, sent slowly
            for _ in range(30):
                gw.send(b"z" * 500)
                assert len(src.framer.buffer) <= MAX_MESSAGE_CHARS
            wait_for(lambda: src.framer.dropped >= 1)
            parsed = src.messages_received
            gw.send(b"</action></message>" + b'<message><action name="brake">0.25</action></message>')
            wait_for(lambda: src.messages_received >= parsed + 2)  # the unterminated one's tail, then the brake
            assert src.poll(1.0).brake == 0.25
        assert len([r for r in caplog.records if r.name.startswith("opends_gym.human.inputs")]) <= 2
    finally:
        src.close()
        gw.close()
