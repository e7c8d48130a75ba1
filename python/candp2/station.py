"""What a gateway and a generic slave share as the PLC and a test engineer see them: a DP
address (its Modbus unit ID), the master's process image through that unit, the status block,
the control register and waiting for a condition (docs/modbus.md, docs/faults.md).

`candp2.Gateway` (gateway.py) and `candp2.Slave` (slave.py) are Stations."""

from __future__ import annotations

import inspect
import time
from typing import (TYPE_CHECKING, Callable, Iterator, Mapping, Self, Sequence, TypeVar,
                    overload)

from .registers import DiagnosisLayout, RegisterMap, StatusValue

if TYPE_CHECKING:
    from .connection import Connection

T = TypeVar("T")

#: How often wait_until() asks again.
POLL_INTERVAL = 0.02


def hex_bytes(data: bytes | bytearray) -> str:
    """b"\\x01\\xab" → "01 AB"."""
    return " ".join("%02X" % b for b in data)


class HexBytes(bytes):
    """Bytes that print in hex like everything else the package shows: repr
    `bytes.fromhex('A8 66 26')`, str `A8 66 26`. Equal to (and usable as) the plain bytes."""

    def __repr__(self) -> str:
        return "bytes.fromhex(%r)" % hex_bytes(self)

    def __str__(self) -> str:
        return hex_bytes(self)


def words_to_bytes(words: Sequence[int]) -> HexBytes:
    """Modbus registers as the bytes they carry, high byte first (docs/modbus.md)."""
    return HexBytes(b"".join(w.to_bytes(2, "big") for w in words))


def bytes_to_words(data: bytes | bytearray) -> list[int]:
    """An even number of bytes as Modbus registers, high byte first (docs/modbus.md)."""
    return [int.from_bytes(data[i:i + 2], "big") for i in range(0, len(data), 2)]


class DiagnosisBytes:
    """What both diagnoses (candp2.Diagnosis, candp2.SlaveDiagnosis) answer as bytes and as a set
    of station status bits: `diag[8]`, `diag[0:6]`, `len(diag)`, `"Ext_Diag" in diag`."""

    raw: bytes
    bits: frozenset[str]

    @staticmethod
    def standard(raw: bytes, layout: DiagnosisLayout) -> tuple[frozenset[str], int | None, int]:
        """The station status bits set, the master holding the lock (None: none) and the
        Ident_Number, read from the standard bytes with the daemon's layout (manual §3.4); a
        byte past the end of `raw` reads as none / 0."""
        bits = frozenset(name for byte, mask, name in layout.bits
                         if byte < len(raw) and raw[byte] & mask)
        master = raw[layout.master_byte] if layout.master_byte < len(raw) else layout.no_master
        ident = 0
        for i in layout.ident_bytes:
            ident = (ident << 8) | (raw[i] if i < len(raw) else 0)
        return bits, None if master == layout.no_master else master, ident

    @overload
    def __getitem__(self, index: int) -> int: ...

    @overload
    def __getitem__(self, index: slice) -> bytes: ...

    def __getitem__(self, index: int | slice) -> int | bytes:
        return self.raw[index]

    def __len__(self) -> int:
        return len(self.raw)

    def __contains__(self, bit: object) -> bool:
        return bit in self.bits


def describe_predicate(predicate: Callable[..., object]) -> str:
    """The lambda's source text ("lambda g: g.state == 'Data_Exch'"), else its repr."""
    try:
        source = inspect.getsource(predicate).strip()
    except (OSError, TypeError):
        return repr(predicate)
    if "lambda" not in source:
        return repr(predicate)
    source = " ".join(source[source.index("lambda"):].split())
    # The statement around the lambda may go on: cut at the parenthesis that closes the call.
    depth = 0
    for i, c in enumerate(source):
        depth += c in "([{"
        depth -= c in ")]}"
        if depth < 0 or (depth == 0 and c == ","):
            return source[:i].rstrip()
    return source.rstrip(",")


def poll_until(evaluate: Callable[[dict[str, object]], T], timeout: float, what: str,
               shown: Callable[[object], str], describe: Callable[[], str]) -> T:
    """The waiting of every wait_until(): `evaluate(seen)` (which records in `seen` what it
    read, by name) until it returns something true, which it returns. After `timeout` seconds
    it raises WaitTimeout: `what` (the predicate's text), what it last read (`shown`) and
    `describe()`."""
    from .errors import WaitTimeout
    deadline = time.monotonic() + timeout
    while True:
        seen: dict[str, object] = {}
        value = evaluate(seen)
        if value:
            return value
        if time.monotonic() >= deadline:
            last = ", ".join("%s=%s" % (k, shown(v)) for k, v in seen.items())
            raise WaitTimeout("%s: not true within %.1f s; last saw %s (predicate returned %s)\n%s"
                              % (what, timeout, last or "nothing", shown(value), describe()))
        time.sleep(POLL_INTERVAL)


# ------------------------------------------------------------------------------- byte views

class ByteView:
    """A fixed-size run of bytes read and written through Modbus, indexed like a bytes object:
    `view[0:6]`, `view[3]`, `view[0:2] = b"..."`, `bytes(view)`, `len(view)`. Subclasses
    provide _registers(), write(), __len__() and the name a wait_until() message shows."""

    def __len__(self) -> int:
        raise NotImplementedError

    def _registers(self, first: int, last: int) -> bytes:
        """The bytes of the view's registers `first`..`last` (register n holds bytes 2n, 2n+1)."""
        raise NotImplementedError

    def read(self, address: int, length: int) -> bytes:
        """`length` bytes from byte `address` of the view."""
        self._check(address, length)
        if length == 0:
            return HexBytes()
        first, last = address // 2, (address + length - 1) // 2
        offset = address - 2 * first
        return HexBytes(self._registers(first, last)[offset:offset + length])

    def write(self, address: int, data: bytes | bytearray | Sequence[int]) -> None:
        raise NotImplementedError

    def _note(self, what: str, value: T) -> T:
        """Records a value read (for wait_until()'s message); `what` is "[0:6]" or "[3]"."""
        return value

    def _check(self, address: int, length: int) -> None:
        if address < 0 or length < 0 or address + length > len(self):
            raise IndexError("%r: bytes %d..%d outside its %d bytes" % (
                self, address, address + length - 1, len(self)))

    def _span(self, key: slice) -> tuple[int, int]:
        start, stop, step = key.indices(len(self))
        if step != 1:
            raise ValueError("byte slices take no step")
        return start, max(0, stop - start)

    @overload
    def __getitem__(self, key: int) -> int: ...

    @overload
    def __getitem__(self, key: slice) -> bytes: ...

    def __getitem__(self, key: int | slice) -> int | bytes:
        if isinstance(key, slice):
            start, length = self._span(key)
            return self._note("[%d:%d]" % (start, start + length), self.read(start, length))
        index = key + len(self) if key < 0 else key
        return self._note("[%d]" % index, self.read(index, 1)[0])

    def __setitem__(self, key: int | slice, value: bytes | bytearray | Sequence[int] | int
                    ) -> None:
        if isinstance(key, slice):
            start, length = self._span(key)
            data = bytes([value]) if isinstance(value, int) else bytes(value)
            if len(data) != length:
                raise ValueError("%d bytes for a %d-byte slice (%r has a fixed size)"
                                 % (len(data), length, self))
            self.write(start, data)
        else:
            if not isinstance(value, int):
                raise TypeError("one byte takes an int")
            self.write(key + len(self) if key < 0 else key, bytes([value]))

    def __bytes__(self) -> bytes:
        return self.read(0, len(self))

    def __iter__(self) -> Iterator[int]:
        return iter(bytes(self))


class Image(ByteView):
    """One direction of the master's PLC process image as seen through one station's unit ID:
    `station.outputs` (Q bytes, writable) and `station.inputs` (I bytes).

    Indexed by PLC byte address like a bytes object: `gw.inputs[0:6]` reads I 0..5,
    `gw.outputs[0:5] = b"\\x51\\0\\0\\0\\0"` writes Q 0..4. One write of up to 246 bytes is one
    Modbus request, so the master sends it in one Data_Exchange (docs/modbus.md
    "Atomicity"); bytes at odd addresses are written as coils, so neighbours are never
    touched."""

    def __init__(self, station: Station, output: bool) -> None:
        self._station = station
        self._output = output

    @property
    def _map(self) -> RegisterMap:
        return self._station.register_map

    def __len__(self) -> int:
        return self._map.image_bytes

    def _note(self, what: str, value: T) -> T:
        return self._station.note(self._station.image_name(self._output) + what, value)

    def _registers(self, first: int, last: int) -> bytes:
        rng = self._map.outputs if self._output else self._map.inputs
        return words_to_bytes(self._station.connection.modbus.read_registers(
            rng.table, rng.first + first, last - first + 1, self._station.address))

    def write(self, address: int, data: bytes | bytearray | Sequence[int]) -> None:
        """Writes `data` at PLC address `address` (outputs only)."""
        if not self._output:
            raise TypeError("the input image is written by the stations, not by the PLC")
        data = bytes(data)
        self._check(address, len(data))
        if not data:
            return
        modbus = self._station.connection.modbus
        unit = self._station.address
        if address % 2 == 0 and len(data) % 2 == 0:
            rng = self._map.outputs
            modbus.write_registers(rng.first + address // 2, bytes_to_words(data), unit)
        else:
            bits = [bool(b >> i & 1) for b in data for i in range(8)]
            modbus.write_coils(self._map.output_bits.first + 8 * address, bits, unit)

    def __repr__(self) -> str:
        return "<%s of %s %d>" % (self._station.image_name(self._output), self._station.kind,
                                  self._station.address)


# ---------------------------------------------------------------------------------- station

class Station:
    """A DP station of a running candp2d, addressed by its DP address (its Modbus unit ID).

    Reads go to the daemon every time (nothing is cached)."""

    #: "gateway" or "slave": in messages and reprs.
    kind = "station"
    #: Types whose str() (not repr()) a wait_until() message shows.
    _SHOWN_AS_TEXT: tuple[type, ...] = ()

    def __init__(self, connection: Connection, address: int) -> None:
        self.connection = connection
        #: The DP address (the Modbus unit ID of the status block and the fault registers).
        self.address = address
        #: The name in the configuration.
        self.name = "%s%d" % (self.kind, address)
        #: The master's output image (PLC Q bytes), writable.
        self.outputs = Image(self, output=True)
        #: The master's input image (PLC I bytes).
        self.inputs = Image(self, output=False)
        self._seen: dict[str, object] | None = None

    @property
    def register_map(self) -> RegisterMap:
        return self.connection.register_map

    def __repr__(self) -> str:
        return "<%s %d (%s)>" % (self.kind.capitalize(), self.address, self.name)

    def image_name(self, output: bool) -> str:
        return "outputs" if output else "inputs"

    def note(self, what: str, value: T) -> T:
        """Records a value read while wait_until() evaluates its predicate (for its message)."""
        if self._seen is not None:
            self._seen[what] = value
        return value

    # ---- the status block ----------------------------------------------------------------

    @property
    def status(self) -> dict[str, StatusValue]:
        """The whole status block by field name (docs/modbus.md), read in one request."""
        m = self.register_map
        words = self.connection.modbus.read_registers(m.status.table, m.status.first,
                                                      m.status.count, self.address)
        return m.decode_status(words)

    def _named(self, status: Mapping[str, StatusValue], field: str) -> str:
        return self.register_map.value_name(field, self.register_map.number(status, field))

    @property
    def state(self) -> str:
        """The DP slave state: "Wait_Prm", "Wait_Cfg" or "Data_Exch"."""
        return self.note("state", self._named(self.status, "dp_state"))

    @property
    def master_state(self) -> str:
        """The master's view of this station ("Data_Exch", "Retry", ...)."""
        return self.note("master_state", self._named(self.status, "master_state"))

    # ---- the control register (docs/faults.md) -------------------------------------------

    def _control(self, command: str) -> None:
        m = self.register_map
        self.connection.modbus.write_register(m.control_register, m.commands[command],
                                              self.address)

    def power_cycle(self) -> None:
        """The station restarts: Wait_Prm with nothing accepted (a gateway's counters 0); the
        master parameterizes it again after its retry time."""
        self._control("power_cycle")

    def reparameterize(self) -> None:
        """The master runs Slave_Diag, Set_Prm, Chk_Cfg again at its next cycle."""
        self._control("reparameterize")

    def master_stop(self) -> None:
        """The master stops addressing the station (a PLC in STOP); with a watchdog it falls
        back to Wait_Prm."""
        self._control("master_stop")

    def master_resume(self) -> None:
        """The master addresses the station again and parameterizes it."""
        self._control("master_resume")

    # ---- waiting ------------------------------------------------------------------------

    def wait_until(self, predicate: Callable[[Self], T], timeout: float = 5.0) -> T:
        """Calls `predicate(station)` until it returns something true, and returns that.

        After `timeout` seconds it raises WaitTimeout saying what the predicate last read
        (`state='Wait_Prm'`, `inputs[0:6]=[A8 66 26 00 00 00]`) and the station's whole state."""
        def evaluate(seen: dict[str, object]) -> T:
            self._seen = seen
            try:
                return predicate(self)
            finally:
                self._seen = None

        return poll_until(evaluate, timeout, describe_predicate(predicate), self._shown,
                          self.describe)

    def _shown(self, value: object) -> str:
        """A value read by a predicate as a wait_until() message shows it: bytes in hex ("A8 00
        26"), the decoded types as their text, anything else as its repr."""
        if isinstance(value, (bytes, bytearray)):
            return "[%s]" % hex_bytes(value)
        if isinstance(value, self._SHOWN_AS_TEXT):
            return str(value)
        return repr(value)

    def describe(self) -> str:
        """The station's state in a few lines."""
        return "%s %d (%s): %s" % (self.kind, self.address, self.name, self.state)
