"""OpenDS's settings-controller server: XML events over TCP, periodic value pushes.

Why: experimenters' tools (OpenDS's `tools/settingscontroller_client`, dashboards,
Wizard-of-Oz consoles) connect to the simulator, subscribe to car values, take over the
ego or a traffic car (`SetVehicleControl`), and fire `remote:` triggers. This server
speaks that protocol (OpenDS `SettingsControllerServer`;
docs/opends-compatibility.md#settings-controller): each request is
`<Message><Event Name="...">value</Event>...</Message>`, answered by one `<Message>` with an `<Event>` per request;
after `EstablishConnection` the subscribed values are pushed every update interval.

It is off unless enabled and binds to 127.0.0.1 unless told otherwise. Each client has
its own thread, at most `max_clients` of them (more are answered `<Error>` and closed); a
client that sends no complete request for `idle_timeout_s` and is not subscribed to pushes
is closed. Requests are bounded (64 KiB) and parsed with entity expansion and network
access off; numbers are ASCII decimals in range; anything malformed gets an `<Error>`
reply and a rate-limited log line, never an exception. Commands that drive the car or
fire triggers (`CONTROL_EVENTS`) can be limited to peers in `control_peers` and/or to
clients that first sent `<Event Name="Authenticate">token</Event>` (docs/hardening.md).
Values are read from the latest `VehicleSnapshot` (`publish`); commands that change the
simulation are queued and applied by `poll` once per physics step, so the server is also an
`InputSource`.
"""

from __future__ import annotations

import contextlib
import hmac
import logging
import math
import queue
import socket
import socketserver
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from lxml import etree

from .inputs.base import InputFrame, InputStatus, TrafficControl
from .snapshot import VehicleSnapshot
from .value_tree import build_tree, matching_paths, schema_tree
from .wire import RateLimitedWarning, ascii_float, ascii_int

log = logging.getLogger(__name__)

MAX_REQUEST_BYTES = 64 * 1024
MIN_INTERVAL_MS = 10
MAX_INTERVAL_MS = 3_600_000  # one hour; 1e308 ms overflowed the push thread's wait
MAX_CLIENTS = 16
IDLE_TIMEOUT_S = 60.0
# events that change the simulation (GetXMLRequest may execute remote triggers)
CONTROL_EVENTS = frozenset({"SetVehicleControl", "SetPedestrianControl", "GetXMLRequest", "ResetPosition"})
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False)


class SettingsControllerServer:
    """The server (see the module docstring). `start()` it; `close()` stops every thread."""

    name = "settings-controller"

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 1000,
        remote_ids: Iterable[str] | Callable[[], Iterable[str]] = (),
        *,
        max_clients: int = MAX_CLIENTS,
        idle_timeout_s: float = IDLE_TIMEOUT_S,
        control_token: str | None = None,
        control_peers: Iterable[str] | None = None,
    ) -> None:
        if max_clients < 1 or not (idle_timeout_s > 0):
            raise ValueError("max_clients must be at least 1 and idle_timeout_s positive")
        self.host, self.requested_port = host, int(port)
        self._remote_ids = remote_ids
        self.max_clients = int(max_clients)
        self.idle_timeout_s = float(idle_timeout_s)
        self.control_token = control_token or None
        self.control_peers = frozenset(control_peers) if control_peers is not None else None
        self.warn = RateLimitedWarning(log)
        self.refused = 0  # connections turned away at the cap
        self._active = 0
        self.snapshot = VehicleSnapshot()
        self._commands: queue.Queue[tuple[str, Any]] = queue.Queue(10000)
        self._ego: tuple[float, float, float] | None = None
        self._clients: set[_Client] = set()
        self._lock = threading.Lock()
        self.requests = 0
        self.errors = 0
        self._server: socketserver.ThreadingTCPServer | None = None
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> SettingsControllerServer:
        owner = self

        class Handler(socketserver.BaseRequestHandler):
            def handle(self) -> None:
                try:
                    _Client(owner, self.request, str(self.client_address[0])).serve()
                finally:
                    with owner._lock:
                        owner._active -= 1

        class Server(socketserver.ThreadingTCPServer):
            allow_reuse_address = True

            def verify_request(self, request: Any, client_address: Any) -> bool:
                return owner._admit(request)

        server = Server((self.host, self.requested_port), Handler)
        server.daemon_threads = True
        self._server = server
        self._thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.1}, name="settings-controller", daemon=True)
        self._thread.start()
        log.info("settings-controller server listening on %s:%d", *self.address)
        return self

    def _admit(self, sock: socket.socket) -> bool:
        """Take a connection only below `max_clients` (before its thread starts)."""
        with self._lock:
            if self._active < self.max_clients:
                self._active += 1
                return True
            self.refused += 1
        self.warn.warn("settings controller: connection refused, %d clients already (max_clients)", self.max_clients)
        with contextlib.suppress(OSError):
            sock.setblocking(False)
            sock.send(_error(f"too many connections (at most {self.max_clients})"))
        return False

    @property
    def address(self) -> tuple[str, int]:
        if self._server is None:
            return (self.host, self.requested_port)
        h, p = self._server.server_address[:2]
        return (str(h), int(p))

    def close(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            c.stop()

    # ------------------------------------------------------------------ simulation side
    def publish(self, snapshot: VehicleSnapshot) -> None:
        """The latest car state (called by the runner after each step)."""
        self.snapshot = snapshot

    def remote_ids(self) -> set[str]:
        ids = self._remote_ids() if callable(self._remote_ids) else self._remote_ids
        return set(ids)

    def poll(self, t_s: float) -> InputFrame:
        f = InputFrame()
        remotes: list[str] = []
        traffic: list[TrafficControl] = []
        commands: list[str] = []
        while True:
            try:
                kind, value = self._commands.get_nowait()
            except queue.Empty:
                break
            if kind == "ego":
                self._ego = value
            elif kind == "remote":
                remotes.append(value)
            elif kind == "traffic":
                traffic.append(value)
            elif kind == "command":
                commands.append(value)
        if self._ego is not None:
            f.steering, f.accelerator, f.brake = self._ego
        f.remote_triggers = tuple(remotes)
        f.traffic_controls = tuple(traffic)
        f.commands = tuple(commands)
        return f

    def status(self) -> InputStatus:
        with self._lock:
            n = len(self._clients)
        host, port = self.address
        return InputStatus(self.name, connected=self._server is not None, message=f"settings controller on {host}:{port}, {n} client(s)")

    def _queue(self, kind: str, value: Any) -> None:
        try:
            self._commands.put_nowait((kind, value))
        except queue.Full:
            self.errors += 1
            self.warn.warn("settings controller: command queue full; %s dropped", kind)

    # ------------------------------------------------------------------ requests
    def handle_message(self, client: _Client, root: etree._Element) -> bytes:
        """Answer one `<Message>` (called on the client's thread)."""
        reply = etree.Element("Message")
        for ev in root.iter("Event"):
            self.requests += 1
            name = ev.get("Name", "")
            value = (ev.text or "").strip()
            try:
                self._authorize(client, name)
                self._event(client, name, value, ev, reply)
            except Exception as e:  # one bad event must not cost the reply to the others
                self.errors += 1
                self.warn.warn("settings controller: event %r from %s failed: %s", name[:40], client.peer, e)
                err = etree.SubElement(reply, "Event", Name="Error")
                err.text = f"{name}: {e}"
        return b'<?xml version="1.0" encoding="UTF-8"?>\n' + etree.tostring(reply) + b"\n"

    def _event(self, client: _Client, name: str, value: str, ev: etree._Element, reply: etree._Element) -> None:
        def event(event_name: str, child: etree._Element | None = None, text: str | None = None) -> None:
            e = etree.SubElement(reply, "Event", Name=event_name)
            if child is not None:
                e.append(child)
            if text is not None:
                e.text = text

        snap = self.snapshot
        if name == "Authenticate":
            ok = self.control_token is not None and hmac.compare_digest(value.encode(), self.control_token.encode())
            if not ok:
                raise PermissionError("wrong token" if self.control_token is not None else "this server has no token")
            client.authenticated = True
            event("Authenticated")
        elif name == "EstablishConnection":
            if value:
                client.interval_ms = _interval(value)
            client.start_pushing()
            event("ConnectionEstablished")
        elif name == "AbolishConnection":
            event("ConnectionAbolished")
            client.closing = True
        elif name == "GetDataSchema":
            event("DataSchema", schema_tree())
        elif name in ("GetSubscriptions", "Subscribe", "Unsubscribe"):
            if name == "Subscribe":
                found = matching_paths(value)
                if not found:
                    raise ValueError(f"no value path matches {value!r}")
                client.subscriptions = client.subscriptions | frozenset(found)  # replaced, never mutated: the pusher reads it
            elif name == "Unsubscribe":
                client.subscriptions = client.subscriptions - frozenset(matching_paths(value))
            event("Subscriptions", build_tree(client.subscriptions, None, names_only=True))
        elif name == "GetSubscribedValues":
            event("SubscribedValues", build_tree(client.subscriptions, snap))
        elif name == "GetValue":
            found = matching_paths(value)
            if not found:
                raise ValueError(f"no value path matches {value!r}")
            event(value, build_tree(found, snap))
        elif name == "GetUpdateInterval":
            event("UpdateInterval", text=str(client.interval_ms))
        elif name == "SetUpdateInterval":
            client.interval_ms = _interval(value)
            event("UpdateInterval", text=str(client.interval_ms))
        elif name == "SetVehicleControl":
            self._vehicle_control(value)
            event("UpdateVehicleControl", text=value)
        elif name == "ResetPosition":  # ours (OpenDS resets by key or CAN): the car back on its last lane position
            self._queue("command", "reset_position")
            event("PositionReset")
        elif name == "SetPedestrianControl":
            raise ValueError("pedestrian control is not supported by this simulation")
        elif name == "GetXMLRequest":
            event("XMLRequest", self._live_data_request(ev, value))
        else:
            raise ValueError(f"unknown event {name!r}")

    def _authorize(self, client: _Client, name: str) -> None:
        """Control events need an allowed peer and, when the server has a token, an authenticated client."""
        if name not in CONTROL_EVENTS:
            return
        if self.control_peers is not None and client.peer not in self.control_peers:
            raise PermissionError(f"{name} is not allowed from {client.peer}")
        if self.control_token is not None and not client.authenticated:
            raise PermissionError(f'{name} needs <Event Name="Authenticate">token</Event> first')

    def _vehicle_control(self, value: str) -> None:
        parts = value.split(";")
        if len(parts) < 4:
            raise ValueError("expected ID;steering;acceleration;brake")
        vid = parts[0].strip()
        try:
            steer, acc, brk = (ascii_float(p) for p in parts[1:4])
        except ValueError:
            raise ValueError("steering, acceleration and brake must be numbers") from None
        if not all(math.isfinite(v) for v in (steer, acc, brk)) or abs(steer) > 1 or not 0 <= acc <= 1 or not 0 <= brk <= 1:
            raise ValueError("steering must be in [-1, 1], acceleration and brake in [0, 1]")
        if vid.lower() == "drivingcar":
            self._queue("ego", (steer, acc, brk))
        elif vid:
            self._queue("traffic", TrafficControl(vid, steer, acc, brk))
        else:
            raise ValueError("empty vehicle ID")

    def _live_data_request(self, ev: etree._Element, value: str) -> etree._Element:
        out = etree.Element("liveDataRequest")
        requests = ev.findall("liveDataRequest")
        if not requests and value.startswith("<"):
            requests = [etree.fromstring(value.encode("utf-8"), _PARSER)]
        if len(requests) != 1 or requests[0].tag != "liveDataRequest":
            err = etree.SubElement(out, "error1" if not requests else "error2")
            err.text = "The XML request is empty" if not requests else "The XML request contains more than one liveDataRequest element"
            return out
        known = self.remote_ids()
        for loc in requests[0].findall("location"):
            le = etree.SubElement(out, "location")
            etree.SubElement(le, "id").text = (loc.findtext("id") or "").strip()
            etree.SubElement(le, "error4").text = "location look-ups need an OpenDRIVE lane model; not available"
        for te in requests[0].findall("triggerExecution"):
            tid = (te.findtext("triggerId") or "").strip()
            node = etree.SubElement(out, "triggerExecution")
            etree.SubElement(node, "triggerId").text = tid
            ok = tid in known
            if ok:
                self._queue("remote", tid)
            etree.SubElement(node, "status").text = "success" if ok else "trigger ID does not exist"
        return out


def _interval(value: str) -> int:
    try:
        ms = ascii_int(value)
    except ValueError:
        raise ValueError(f"update interval must be a whole number of milliseconds, not {value[:40]!r}") from None
    if not MIN_INTERVAL_MS <= ms <= MAX_INTERVAL_MS:
        raise ValueError(f"update interval must be {MIN_INTERVAL_MS}..{MAX_INTERVAL_MS} ms")
    return ms


class _Client:
    """One connection: reads requests, answers them, pushes subscribed values."""

    def __init__(self, server: SettingsControllerServer, sock: socket.socket, peer: str = "") -> None:
        self.server = server
        self.sock = sock
        self.peer = peer
        self.authenticated = False
        self.interval_ms = 1000
        self.subscriptions: frozenset[str] = frozenset()
        self.closing = False
        self._stop = threading.Event()
        self._write_lock = threading.Lock()
        self._pusher: threading.Thread | None = None

    def serve(self) -> None:
        srv = self.server
        with srv._lock:
            srv._clients.add(self)
        buf = b""
        self.sock.settimeout(0.1)
        self.last_request = time.monotonic()
        try:
            while not self._stop.is_set() and not self.closing:
                try:
                    data = self.sock.recv(65536)
                except TimeoutError:
                    if self._pusher is None and time.monotonic() - self.last_request > srv.idle_timeout_s:
                        srv.warn.warn("settings controller: %s idle for %g s; closed", self.peer, srv.idle_timeout_s)
                        self.send(_error(f"idle for {srv.idle_timeout_s:g} s; closing"))
                        break
                    continue
                if not data:
                    break
                buf += data
                buf = self._consume(buf)
        except OSError as e:
            log.info("settings controller: client gone (%s)", e)
        finally:
            self.stop()
            with srv._lock:
                srv._clients.discard(self)
            with contextlib.suppress(OSError):
                self.sock.close()

    def _consume(self, buf: bytes) -> bytes:
        """Answer every complete `<Message>` in the buffer; return the rest."""
        while True:
            end = buf.find(b"</Message>")
            if end < 0:
                if len(buf) > MAX_REQUEST_BYTES:
                    self.server.errors += 1
                    self.server.warn.warn("settings controller: request over %d bytes without </Message> dropped", MAX_REQUEST_BYTES)
                    self.send(_error("request too large"))
                    return b""
                return buf
            end += len(b"</Message>")
            chunk, buf = buf[:end], buf[end:]
            self.last_request = time.monotonic()
            start = chunk.rfind(b"<Message")
            if start < 0 or len(chunk) > MAX_REQUEST_BYTES:
                self.server.errors += 1
                self.send(_error("No valid XML data received"))
                continue
            try:
                root = etree.fromstring(chunk[start:], _PARSER)
            except etree.XMLSyntaxError as e:
                self.server.errors += 1
                self.server.warn.warn("settings controller: malformed request from %s: %s", self.peer, e)
                self.send(_error("No valid XML data received"))
                continue
            self.send(self.server.handle_message(self, root))

    def send(self, data: bytes) -> None:
        with self._write_lock:
            try:
                self.sock.sendall(data)
            except OSError:
                self._stop.set()

    def start_pushing(self) -> None:
        if self._pusher is None:
            self._pusher = threading.Thread(target=self._push, name="settings-controller-push", daemon=True)
            self._pusher.start()

    def _push(self) -> None:
        while not self._stop.wait(self.interval_ms / 1000.0):
            try:
                reply = etree.Element("Message")
                ev = etree.SubElement(reply, "Event", Name="SubscribedValues")
                ev.append(build_tree(self.subscriptions, self.server.snapshot))
            except Exception as e:  # a value that cannot be written must not end the pushes
                self.server.errors += 1
                self.server.warn.warn("settings controller: push to %s failed: %s", self.peer, e)
                continue
            self.send(etree.tostring(reply) + b"\n")

    def stop(self) -> None:
        self._stop.set()


def _error(text: str) -> bytes:
    root = etree.Element("Message")
    etree.SubElement(root, "Error").text = text
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + etree.tostring(root) + b"\n"
