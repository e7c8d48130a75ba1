"""The service manager's end of sd_notify(3): a unix datagram socket candp2d reports to.

candp2d sends READY=1 once every listener is open, with the addresses it bound in X_CANDP2_*
variables (docs/daemon.md "systemd"); a failed start sends STATUS=cannot start: ... instead.
"""

from __future__ import annotations

import os
import socket
import threading


#: How many datagrams a NotifySocket keeps (the newest).
KEEP = 1000


class NotifySocket:
    """A bound AF_UNIX datagram socket at `path` (give it to candp2d as NOTIFY_SOCKET).

    After READY=1 the daemon goes on sending STATUS= lines; `drain()` reads them in a thread
    until close(), since sd_notify(3) blocks the sender when nobody reads (and logs an error
    when the socket is gone)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(path)
        self.messages: list[dict[str, str]] = []
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None

    def receive(self, timeout: float) -> dict[str, str] | None:
        """The next datagram as {"READY": "1", "STATUS": "...", ...}, or None after `timeout`."""
        self.sock.settimeout(max(timeout, 0.001))
        try:
            data = self.sock.recv(65536)
        except socket.timeout:
            return None
        fields = dict(line.split("=", 1) for line in data.decode(errors="replace").splitlines()
                      if "=" in line)
        self.messages.append(fields)
        del self.messages[:-KEEP]
        return fields

    def drain(self) -> None:
        """Reads every further datagram in a background thread until close()."""
        def run() -> None:
            while not self._closing.is_set():
                try:
                    self.receive(0.2)
                except OSError:
                    return
        self._thread = threading.Thread(target=run, name="candp2-notify", daemon=True)
        self._thread.start()

    def last(self, key: str) -> str | None:
        """The last value of `key` received so far."""
        for m in reversed(self.messages):
            if key in m:
                return m[key]
        return None

    def close(self) -> None:
        self._closing.set()
        if self._thread is not None:
            # An empty datagram of our own wakes the reading thread at once.
            try:
                with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as wake:
                    wake.sendto(b"", self.path)
            except OSError:
                pass
            self._thread.join(timeout=5)
        self.sock.close()
        try:
            os.unlink(self.path)
        except OSError:
            pass


def parse_address(text: str) -> tuple[str, int]:
    """"127.0.0.1:1502" → ("127.0.0.1", 1502)."""
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit():
        raise ValueError("expected HOST:PORT, got %r" % text)
    return host, int(port)


def parse_socketcand(text: str) -> dict[str, tuple[str, int]]:
    """X_CANDP2_SOCKETCAND "can0=127.0.0.1:40314,can1=..." → {"can0": ("127.0.0.1", 40314)}."""
    out: dict[str, tuple[str, int]] = {}
    for item in filter(None, text.split(",")):
        name, _, address = item.partition("=")
        out[name] = parse_address(address)
    return out
