"""A TCP client that reconnects by itself and never raises into the simulation loop.

Why: OpenDS connects *out* to its CAN gateway and its external visualization server.
Lab networks drop; gateways restart. The session must keep running, show the state of
the link, and pick the connection up again, so all socket work happens on one
background thread per connection, with received bytes handed to a callback and
outgoing text queued.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from collections.abc import Callable

log = logging.getLogger(__name__)

READ_CHUNK = 10000  # OpenDS reads at most 10000 characters per socket read


class ReconnectingClient:
    """Connect to host:port; on loss, retry with exponential backoff (0.25 s .. `max_backoff_s`)."""

    def __init__(
        self,
        host: str,
        port: int,
        on_data: Callable[[bytes], None] | None = None,
        on_connect: Callable[[], None] | None = None,
        name: str = "tcp",
        max_backoff_s: float = 5.0,
        read_timeout_s: float = 0.05,
        goodbye: bytes | None = None,
    ) -> None:
        self.host, self.port = host, int(port)
        self.on_data = on_data
        self.on_connect = on_connect
        self.name = name
        self.max_backoff_s = max_backoff_s
        self.read_timeout_s = read_timeout_s
        self.goodbye = goodbye
        self.connected = False
        self.state = "connecting"
        self.connections = 0
        self.errors = 0
        self.dropped = 0
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._sock: socket.socket | None = None
        self._thread = threading.Thread(target=self._run, name=f"{name}-client", daemon=True)

    def start(self) -> ReconnectingClient:
        self._thread.start()
        return self

    def send(self, data: str | bytes) -> bool:
        """Send now from the caller's thread; False (dropped) when not connected or the peer is stuck."""
        sock = self._sock
        if sock is None or not self.connected:
            return False
        payload = data.encode("utf-8") if isinstance(data, str) else data
        with self._send_lock:
            try:
                sock.sendall(payload)
            except OSError as e:  # a full buffer or a dying connection: the reader thread notices the loss
                self.dropped += 1
                log.debug("%s: send failed: %s", self.name, e)
                return False
        return True

    def close(self, timeout_s: float = 1.0) -> None:
        self._stop.set()
        self._thread.join(timeout_s)

    # ------------------------------------------------------------------ thread
    def _run(self) -> None:
        backoff = 0.25
        while not self._stop.is_set():
            try:
                sock = socket.create_connection((self.host, self.port), timeout=2.0)
            except OSError as e:
                self.state = f"cannot reach {self.host}:{self.port} ({e.strerror or e}); retrying in {backoff:.1f} s"
                log.debug("%s: %s", self.name, self.state)
                self._stop.wait(backoff)
                backoff = min(self.max_backoff_s, backoff * 2.0)
                continue
            backoff = 0.25
            self._serve(sock)
        self.connected = False

    def _serve(self, sock: socket.socket) -> None:
        sock.settimeout(self.read_timeout_s)
        self._sock = sock
        self.connected = True
        self.connections += 1
        self.state = f"connected to {self.host}:{self.port}"
        log.info("%s: %s", self.name, self.state)
        if self.on_connect is not None:
            self._call(self.on_connect)
        try:
            while not self._stop.is_set():
                try:
                    data = sock.recv(READ_CHUNK)
                except TimeoutError:
                    continue
                if not data:
                    raise ConnectionError("closed by the peer")
                if self.on_data is not None:
                    self._call(self.on_data, data)
            if self.goodbye:
                with self._send_lock, contextlib.suppress(OSError):
                    sock.sendall(self.goodbye)
        except (OSError, ConnectionError) as e:
            self.errors += 1
            self.state = f"connection to {self.host}:{self.port} lost ({e}); reconnecting"
            log.warning("%s: %s", self.name, self.state)
        finally:
            self.connected = False
            self._sock = None
            with contextlib.suppress(OSError):
                sock.close()

    def _call(self, fn: Callable[..., None], *args: object) -> None:
        try:
            fn(*args)
        except Exception:  # a bug in a handler must not kill the connection thread
            self.errors += 1
            log.exception("%s: handler failed", self.name)
