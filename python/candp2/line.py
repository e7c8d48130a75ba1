"""The built-in master's PROFIBUS line as an analyser sees it (docs/profibus.md "The line in time"
and "Line statistics"): its baud rate, the bus cycle candp2d measures, the live list and each
station's counters, as `/api/v1/status` shows them under "line"; and faults on cue on the line
(docs/faults.md "Line faults") through the Modbus line fault registers."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

from .registers import LINE_FAULT_FIELDS

if TYPE_CHECKING:
    from .connection import Connection

#: The longest fault or noise and the highest count or period the registers hold.
_REGISTER_MAX = 0xFFFF


@dataclass(frozen=True)
class BusCycle:
    """The measured bus cycle (one token rotation) in microseconds: the last, the shortest, the
    mean and the longest, over `cycles` rotations."""

    last: int
    min: int
    mean: int
    max: int
    cycles: int


@dataclass(frozen=True)
class LineFault:
    """A station's active line fault: its `kind` ("corrupt", "silent", "late",
    "double_address"), the answers it still spoils (`remaining`, 0 with a duration), every how
    many requests (`every`) and the time left (`remaining_ms`, 0 with a count)."""

    kind: str
    remaining: int
    every: int
    remaining_ms: int


@dataclass(frozen=True)
class LiveList:
    """The live list: configured stations that answer (`ok`), configured ones that do not
    (`missing`), answering ones that are not configured (`phantom`); DP addresses, ascending."""

    ok: tuple[int, ...]
    missing: tuple[int, ...]
    phantom: tuple[int, ...]


def _counter(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


class LineStation:
    """One address of the line: `address`, `live` ("ok", "missing", "phantom", "none"), `fault`
    (LineFault or None), and the analyser's counters under the names the status document gives
    them (lost, syncs, repeats, repeats_max, illegals, diagnostics, docs/profibus.md "Line
    statistics"): as attributes (`station.repeats`) and in `counters`."""

    def __init__(self, address: int, live: str, fault: LineFault | None,
                 counters: Mapping[str, int]) -> None:
        self.address = address
        self.live = live
        self.fault = fault
        self.counters: dict[str, int] = dict(counters)

    @classmethod
    def from_status(cls, entry: Mapping[str, Any]) -> LineStation:
        """A station of the document's `stations` list: every number but the address is a
        counter."""
        f = entry.get("fault")
        fault = None if f is None else LineFault(str(f["kind"]), int(f["remaining"]),
                                                 int(f["every"]), int(f["remaining_ms"]))
        counters = {k: int(v) for k, v in entry.items() if k != "address" and _counter(v)}
        return cls(int(entry["address"]), str(entry.get("live", "none")), fault, counters)

    def __getattr__(self, name: str) -> int:
        counters: dict[str, int] = self.__dict__.get("counters", {})
        if name in counters:
            return counters[name]
        raise AttributeError("line station %s has no counter %r (counters: %s)"
                             % (self.__dict__.get("address", "?"), name,
                                ", ".join(counters) or "none in the status document"))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, LineStation):
            return NotImplemented
        return (self.address, self.live, self.fault, self.counters) == \
            (other.address, other.live, other.fault, other.counters)

    def __hash__(self) -> int:
        return hash((self.address, self.live))

    def __repr__(self) -> str:
        counters = " ".join("%s=%d" % kv for kv in self.counters.items())
        fault = " fault=%s" % self.fault.kind if self.fault else ""
        return "<LineStation %d %s %s%s>" % (self.address, self.live, counters, fault)


@dataclass(frozen=True)
class Line:
    """The line when it was read (read `daemon.line` again for newer figures): `baud` (bit/s);
    on a line in time (`master.baud`) the measured `bus_cycle_us`, the requests the master
    repeated (`retries`) and its FDL-Status requests into the GAP (`gap_polls`), None in
    profibus.role "master"; the `live_list`, the `stations` (LineStation), the illegal telegrams
    no station was blamed for (`illegals_unattributed`) and the noise still on the line
    (`noise_remaining_ms`). `inject()` and `noise()` act on the running daemon."""

    baud: int
    bus_cycle_us: BusCycle | None
    retries: int | None
    gap_polls: int | None
    live_list: LiveList = LiveList((), (), ())
    stations: tuple[LineStation, ...] = ()
    illegals_unattributed: int = 0
    noise_remaining_ms: int = 0
    connection: Connection | None = field(default=None, repr=False, compare=False)

    @classmethod
    def from_status(cls, line: Mapping[str, Any], connection: Connection | None = None) -> Line:
        """The `line` object of GET /api/v1/status (docs/daemon.md "HTTP face")."""
        c = line.get("bus_cycle_us")
        cycle = None if c is None else BusCycle(int(c["last"]), int(c["min"]), int(c["mean"]),
                                                int(c["max"]), int(c["cycles"]))
        live = line.get("live_list", {})

        def addresses(state: str) -> tuple[int, ...]:
            return tuple(int(a) for a in live.get(state, ()))

        def optional(key: str) -> int | None:
            return None if line.get(key) is None else int(line[key])

        return cls(int(line["baud"]), cycle, optional("retries"), optional("gap_polls"),
                   LiveList(addresses("ok"), addresses("missing"), addresses("phantom")),
                   tuple(LineStation.from_status(s) for s in line.get("stations", ())),
                   int(line.get("illegals_unattributed", 0)),
                   int(line.get("noise_remaining_ms", 0)), connection)

    def station(self, address: int) -> LineStation:
        """The station at this DP address; one the line never saw nor configured has live
        "none" and every counter 0."""
        for s in self.stations:
            if s.address == address:
                return s
        names = self.stations[0].counters if self.stations else {}
        return LineStation(address, "none", None, {name: 0 for name in names})

    # ---- faults on cue (docs/faults.md "Line faults") ----------------------------------------

    def _connection(self) -> Connection:
        if self.connection is None:
            raise RuntimeError("this Line was not read from a daemon (Line.from_status without "
                               "a connection): read daemon.line to inject faults")
        return self.connection

    def inject(self, address: int, kind: str, count: int | None = None, every: int = 1,
               for_ms: int | None = None) -> None:
        """Gives station `address` a line fault (docs/faults.md "Line faults"): `kind` one of
        "corrupt", "silent", "late", "double_address" ("none" cancels), for its next `count`
        answers (default 1) or for `for_ms` milliseconds, spoiling every `every`-th request.
        Written to the Modbus line fault registers of unit `address` in one request."""
        connection = self._connection()
        rm = connection.register_map
        if kind not in rm.line_fault_kinds:
            raise ValueError("line fault kind %r: expected one of %s"
                             % (kind, ", ".join(rm.line_fault_kinds)))
        if count is not None and for_ms is not None:
            raise ValueError("give count or for_ms, not both")
        for name, value in (("count", count), ("every", every), ("for_ms", for_ms)):
            if value is not None and not 1 <= value <= _REGISTER_MAX:
                raise ValueError("%s %d: expected 1..%d" % (name, value, _REGISTER_MAX))
        values = {"kind": rm.line_fault_kinds.index(kind),
                  "count": 0 if for_ms is not None else (1 if count is None else count),
                  "every": every, "for_ms": for_ms or 0}
        # One write multiple from the kind register (kind, count, every, for_ms; RegisterMap
        # checks they follow each other): the fault takes effect with it.
        connection.modbus.write_registers(rm.line_fault_registers["kind"],
                                          [values[n] for n in LINE_FAULT_FIELDS], address)

    def noise(self, for_ms: int) -> None:
        """Noise on the whole line for `for_ms` milliseconds: every telegram that starts in it
        is garbled (docs/faults.md "Line faults")."""
        if not 1 <= for_ms <= _REGISTER_MAX:
            raise ValueError("for_ms %d: expected 1..%d" % (for_ms, _REGISTER_MAX))
        connection = self._connection()
        rm = connection.register_map
        # The register is the line's, under any unit: a configured station's.
        unit = self.stations[0].address if self.stations else rm.first_gateway_units[0]
        connection.modbus.write_register(rm.line_fault_registers["noise_for_ms"], for_ms, unit)
