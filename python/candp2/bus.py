"""A CAN bus of candp2d as a python-can bus: the bus's socketcand export (the `socketcand` key
of a virtual bus, docs/configuration.md), raw mode.

`Bus` is a `can.BusABC` (python-can's one bus contract: recv(), send(), filters, iteration,
send_periodic(), Notifier) plus what a test needs: `expect()` a frame or fail listing what was
seen, `expect_no_frame()`, `drain()`, `record()` a candump -L log; and from `daemon.bus()`, on a
bus in time, what the daemon measures of it (`timing()`, `load`, `identifiers`, ...;
candp2.timing) and CAN faults on cue (`fault()`).

Why not python-can's own `interface="socketcand"`: the python-can of Debian 12 (4.1.0) loses a
frame whenever a TCP read ends inside one and marks every received frame as extended (both fixed
in later python-can releases; docs/python.md "Decisions"). The protocol is small (socketcand's
raw mode, docs/transports.md), so the framing lives here as pure functions (`format_send`,
`parse_element`), the way python-can keeps framing apart from its transports.
"""

from __future__ import annotations

import collections
import os
import select
import socket
import threading
import time
from typing import IO, TYPE_CHECKING, Any, Callable, Deque, Iterable, Mapping

from can.bus import BusABC  # python3-can
from can.exceptions import CanError, CanInitializationError, CanOperationError
from can.message import Message

from .errors import Candp2Error, FrameNotSeen, UnexpectedFrame
from .timing import BusLoad, BusTiming, CanFaultInForce, IdentifierTiming, can_fault_request

if TYPE_CHECKING:
    from .connection import Connection

#: Longest element we accept (a `< frame ... >` with 8 data bytes has about 50 characters).
MAX_ELEMENT = 256
#: How many received frames a Bus remembers for failure messages (`history`).
HISTORY = 200

# ----------------------------------------------------------------------- framing (pure)


def frame_text(msg: Message) -> str:
    """candump notation: "309#0B0A0F0E0D0C", "12345678#01" (29-bit), "123#R" (remote)."""
    ident = "%08X" % msg.arbitration_id if msg.is_extended_id else "%03X" % msg.arbitration_id
    if msg.is_remote_frame:
        return ident + "#R"
    return ident + "#" + bytes(msg.data).hex().upper()


def candump_line(msg: Message, interface: str) -> str:
    """One `candump -L` line: "(1700000000.123456) can0 309#0B0A0F0E0D0C"."""
    return "(%.6f) %s %s" % (msg.timestamp, interface, frame_text(msg))


def format_send(msg: Message) -> str:
    """The socketcand raw-mode command sending `msg`: "< send 309 6 b a f e d c >" (identifier
    3 hex digits for 11-bit, 8 for 29-bit)."""
    if msg.is_remote_frame or msg.is_error_frame:
        raise CanOperationError("socketcand cannot send remote or error frames")
    if msg.dlc > 8 or len(msg.data) > 8:
        raise CanOperationError("socketcand carries classic CAN frames (at most 8 bytes)")
    ident = "%08X" % msg.arbitration_id if msg.is_extended_id else "%03X" % msg.arbitration_id
    data = bytes(msg.data)
    return "< send %s %d %s>" % (ident, len(data), "".join("%x " % b for b in data))


def parse_element(element: str, channel: str | None = None) -> Message | None:
    """A server's `< frame ID SECONDS.USECONDS HEX >` as a Message (8-digit identifiers
    are 29-bit); `< error CLASS SECONDS.USECONDS >` as an error frame; None for anything else
    (`< ok >`, `< hi >`, text errors)."""
    words = element.strip("<> \t\r\n").split()
    if len(words) < 3 or words[0] not in ("frame", "error"):
        return None
    try:
        ident = int(words[1], 16)
        stamp = float(words[2])
        if words[0] == "error":
            return Message(timestamp=stamp, arbitration_id=ident, is_error_frame=True,
                           channel=channel)
        data = bytes.fromhex(words[3]) if len(words) > 3 else b""
    except ValueError:
        return None
    return Message(timestamp=stamp, arbitration_id=ident, is_extended_id=len(words[1]) == 8,
                   data=data, channel=channel)


class ElementSplitter:
    """Splits a byte stream into `< ... >` elements, keeping a partial element for the next
    chunk (whatever stands outside an element is dropped)."""

    def __init__(self) -> None:
        self._buffer = ""

    def feed(self, text: str) -> list[str]:
        self._buffer += text
        out: list[str] = []
        while True:
            start = self._buffer.find("<")
            if start < 0:
                self._buffer = ""
                return out
            end = self._buffer.find(">", start)
            if end < 0:
                self._buffer = self._buffer[start:]
                if len(self._buffer) > MAX_ELEMENT:
                    self._buffer = ""
                return out
            out.append(self._buffer[start:end + 1])
            self._buffer = self._buffer[end + 1:]


# -------------------------------------------------------------------------- connection


class _Connection:
    """One socketcand raw-mode connection: hi, open CHANNEL, rawmode."""

    def __init__(self, host: str, port: int, channel: str, timeout: float) -> None:
        self.splitter = ElementSplitter()
        self.pending: Deque[str] = collections.deque()
        self.channel = channel
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as e:
            raise CanInitializationError("socketcand %s:%d: %s" % (host, port, e)) from e
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            self._expect("< hi >", timeout)
            self.sock.sendall(("< open %s >" % channel).encode())
            self._expect("< ok >", timeout)
            self.sock.sendall(b"< rawmode >")
            self._expect("< ok >", timeout)
        except BaseException:
            self.sock.close()
            raise

    def _expect(self, want: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while True:
            element = self.next_element(max(0.0, deadline - time.monotonic()))
            if element is None:
                raise CanInitializationError("socketcand: no %s within %.1f s"
                                             % (want, timeout))
            if element.split() == want.split():
                return
            if element.startswith("< error"):
                raise CanInitializationError("socketcand answered %s (wanted %s)"
                                             % (element, want))

    def next_element(self, timeout: float | None) -> str | None:
        """The next element, waiting at most `timeout` seconds (None: forever)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self.pending:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self.sock], [], [], left)
            if not ready:
                return None
            chunk = self.sock.recv(65536)
            if not chunk:
                raise CanOperationError("socketcand connection closed by candp2d")
            self.pending.extend(self.splitter.feed(chunk.decode("ascii", errors="replace")))
        return self.pending.popleft()

    def close(self) -> None:
        self.sock.close()


# --------------------------------------------------------------------------------- Bus


class Recorder:
    """A `candump -L` log of everything on the bus, written by a thread on its own socketcand
    connection from the moment `Bus.record()` returns until `stop()` (or the end of a `with`
    block). `frames` counts the lines written."""

    def __init__(self, host: str, port: int, channel: str, path: str | os.PathLike[str],
                 interface: str, timeout: float) -> None:
        self.path = os.fspath(path)
        self.frames = 0
        self._connection = _Connection(host, port, channel, timeout)
        self._file: IO[str] = open(self.path, "w")
        self._interface = interface
        self._stop = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="candp2-record-" + interface,
                                        daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                element = self._connection.next_element(0.05)
                msg = parse_element(element) if element else None
                if msg is not None and not msg.is_error_frame:
                    self._file.write(candump_line(msg, self._interface) + "\n")
                    self._file.flush()
                    self.frames += 1
        except (OSError, CanError) as e:
            if not self._stop.is_set():
                self._error = e

    def stop(self) -> None:
        """Stops recording and closes the file; raises what ended the recording early."""
        self._stop.set()
        self._thread.join(timeout=5)
        self._connection.close()
        self._file.close()
        if self._error is not None:
            raise Candp2Error("recording %s stopped early: %s" % (self.path, self._error))

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class Bus(BusABC):
    """A python-can bus on one of candp2d's socketcand exports.

    Get it with `daemon.bus(name)`, or construct it: `Bus(channel, host, port)`. It receives
    every frame on the bus (the gateways', the simulated drives', other clients') and sends
    onto it. `history` keeps the last frames received, newest last."""

    def __init__(self, channel: str, host: str, port: int, timeout: float = 5.0,
                 can_filters: Any = None, *, explain: Callable[[int], str] | None = None,
                 daemon: Connection | None = None, name: str | None = None,
                 **kwargs: object) -> None:
        #: `explain(can_id)`: what of the daemon uses that identifier, for a failed expect()
        #: (`daemon.bus()` gives one: the slots and drives using it, the drives' state).
        self.explain = explain
        #: The daemon and its name of the bus (`daemon.bus()` gives them): timing and faults.
        self.daemon = daemon
        self.name = name if name is not None else channel
        self.host = host
        self.port = port
        self.timeout = timeout
        self._connection = _Connection(host, port, channel, timeout)
        self.channel_info = "candp2 socketcand %s:%d channel %s" % (host, port, channel)
        self.history: Deque[Message] = collections.deque(maxlen=HISTORY)
        self._recorders: list[Recorder] = []
        self._closed = False
        super().__init__(channel=channel, can_filters=can_filters, **kwargs)
        self.channel = channel

    def _recv_internal(self, timeout: float | None) -> tuple[Message | None, bool]:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            element = self._connection.next_element(left)
            if element is None:
                return None, False
            msg = parse_element(element, self.channel)
            if msg is not None:
                self.history.append(msg)
                return msg, False

    def send(self, msg: Message, timeout: float | None = None) -> None:
        """Puts `msg` on the bus (classic data frames; 8-digit identifiers for 29-bit)."""
        try:
            self._connection.sock.sendall(format_send(msg).encode())
        except OSError as e:
            raise CanOperationError("socketcand send: %s" % e) from e

    def shutdown(self) -> None:
        if self._closed:
            return
        self._closed = True
        for r in self._recorders:
            r.stop()
        self._connection.close()
        super().shutdown()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()

    # ---- for tests -----------------------------------------------------------------------

    def drain(self) -> list[Message]:
        """Receives and returns whatever has arrived already (waits for nothing)."""
        out: list[Message] = []
        while True:
            msg = self.recv(timeout=0)
            if msg is None:
                return out
            out.append(msg)

    def expect(self, can_id: int, data: bytes | bytearray | Iterable[int] | None = None,
               timeout: float = 1.0) -> Message:
        """Receives until a frame with identifier `can_id` (and exactly `data`, if given)
        arrives and returns it; frames before it are passed over. After `timeout` seconds
        raises FrameNotSeen listing every frame seen meanwhile in candump notation."""
        want = None if data is None else bytes(data)
        seen: list[Message] = []
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            msg = self.recv(timeout=max(0.0, left)) if left > 0 else None
            if msg is None:
                break
            seen.append(msg)
            if msg.arbitration_id == can_id and not msg.is_error_frame and (
                    want is None or bytes(msg.data) == want):
                return msg
        wanted = "%03X#%s" % (can_id, "*" if want is None else want.hex().upper())
        message = "frame %s not seen on %s within %.1f s; saw %s" % (
            wanted, self.channel, timeout, _listing(seen))
        if self.explain is not None:
            message += "\n" + self.explain(can_id)
        raise FrameNotSeen(message, list(seen))

    def expect_no_frame(self, can_id: int | None = None, duration: float = 0.5) -> None:
        """Receives for `duration` seconds; raises UnexpectedFrame listing them if a frame
        (with identifier `can_id`, if given) arrived."""
        bad: list[Message] = []
        seen: list[Message] = []
        deadline = time.monotonic() + duration
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            msg = self.recv(timeout=left)
            if msg is None:
                break
            seen.append(msg)
            if can_id is None or msg.arbitration_id == can_id:
                bad.append(msg)
        if bad:
            what = "any frame" if can_id is None else "a frame %03X#*" % can_id
            raise UnexpectedFrame("%s on %s within %.1f s: saw %s" % (
                what, self.channel, duration, _listing(seen)), list(seen))

    # ---- the bus in time (docs/can-bus.md "Seen from outside") -------------------------------

    def _daemon(self) -> Connection:
        if self.daemon is None:
            raise Candp2Error("this Bus was not opened by daemon.bus(): it has no daemon to read "
                              "the bus's timing from or to send faults to")
        return self.daemon

    def timing(self) -> BusTiming:
        """What the daemon measured of this bus, read now (GET /api/v1/status): bit rate, exact
        load, frames, lost frames, each identifier's period, jitter and latency (ms). On an
        ideal bus NotTimed says that it needs a bit rate."""
        for b in self._daemon().http_status().get("buses", []):
            if b.get("name") == self.name:
                return BusTiming.from_status(b)
        raise Candp2Error("the status document has no bus %r" % self.name)

    @property
    def timed_bitrate(self) -> int:
        """The bus's bit rate (bit/s), read now."""
        return self.timing().timed_bitrate

    @property
    def load(self) -> BusLoad:
        """The exact load of the last complete second and of the most loaded one (%), read now."""
        return self.timing().load

    @property
    def frames_on_bus(self) -> int:
        """Frames that started on the bus, read now."""
        return self.timing().frames_on_bus

    @property
    def tx_lost(self) -> int:
        """Frames lost past a full transmit queue (any node), read now."""
        return self.timing().tx_lost

    @property
    def identifiers(self) -> Mapping[int, IdentifierTiming]:
        """Each identifier's data frames: frames, period, jitter, latency (ms), read now; read
        `timing()` once for several figures of one moment."""
        return self.timing().identifiers

    @property
    def faults(self) -> tuple[CanFaultInForce, ...]:
        """The CAN faults on cue in force on the bus, each with what is left of its count or
        time (docs/can-bus.md "Seen from outside"), read now."""
        return self.timing().faults

    def fault(self, kind: str, count: int | None = None, every: int = 1,
              for_ms: int | None = None, gateway: int | None = None) -> None:
        """A CAN fault on cue (docs/faults.md "CAN faults"): `kind` one of "error_frames" (the
        gateway's next frames end in an error frame), "unplugged", "wrong_bitrate", "noise" (the
        whole bus; needs `for_ms`), "none" (cancels), for the next `count` frames (default 1)
        or for `for_ms` milliseconds, one frame in every `every` ("unplugged", "wrong_bitrate":
        until "none", or ending by themselves after `for_ms`); on the node of `gateway` (a DP
        address; default the first gateway on the bus). Written to the Modbus CAN fault block
        (docs/modbus.md "CAN fault block") in one request; NotTimed on an ideal bus, ValueError
        for a bad kind or value (naming the good ones), ModbusError when the daemon refuses."""
        daemon = self._daemon()
        rm = daemon.register_map
        gateways = [g.dp_address for g in rm.gateways
                    if g.bus == self.name and g.dp_address in rm.can_fault_units]
        request = can_fault_request(rm.can_fault_registers, rm.can_fault_kinds, gateways,
                                    self.name, kind, count, every, for_ms, gateway)
        daemon.modbus.write_registers(request.register, request.values, request.unit)

    def record(self, path: str | os.PathLike[str]) -> Recorder:
        """Starts writing every frame on the bus to `path` as a `candump -L` log (readable by
        canplayer and `candp2 replay`) until the Recorder is stopped or the bus shut down."""
        recorder = Recorder(self.host, self.port, self.channel, path, self.channel,
                            self.timeout)
        self._recorders.append(recorder)
        return recorder


def _listing(frames: list[Message]) -> str:
    if not frames:
        return "no frames"
    return "%d frame%s: %s" % (len(frames), "" if len(frames) == 1 else "s",
                               " ".join(frame_text(m) for m in frames))
