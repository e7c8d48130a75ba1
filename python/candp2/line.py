"""The built-in master's PROFIBUS line as an analyser sees it (docs/profibus.md "The line in time"
and "Line statistics"): its baud rate, the bus cycle candp2d measures, the live list and each
station's counters, as `/api/v1/status` shows them under "line"; faults on cue on the line
(docs/faults.md "Line faults") through the Modbus line fault registers; and waiting for a
counter (`wait_until`, like a gateway's)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping, Sequence, TypeVar

from .registers import LINE_FAULT_FIELDS
from .station import describe_predicate, poll_until

if TYPE_CHECKING:
    from .connection import Connection

#: The longest fault or noise and the highest count or period the registers hold.
_REGISTER_MAX = 0xFFFF

T = TypeVar("T")


def duration_text(us: int) -> str:
    """Microseconds in the unit that reads: "912 µs", "252.4 ms", "1.17 s"."""
    if us < 1000:
        return "%d µs" % us
    if us < 1000000:
        return "%.1f ms" % (us / 1000)
    return "%.2f s" % (us / 1000000)


class _Recorded:
    """Records the public values read from it while a wait_until() evaluates its predicate
    (`_seen`, under `_label` + the name), for the message of a wait that gave up."""

    _seen: ClassVar[dict[str, object] | None] = None
    _label: ClassVar[str] = ""

    def _record(self, seen: dict[str, object] | None, label: str) -> None:
        object.__setattr__(self, "_seen", seen)
        object.__setattr__(self, "_label", label)

    def describe(self) -> str:
        raise NotImplementedError

    if not TYPE_CHECKING:  # to a type checker every attribute keeps its own type
        def __getattribute__(self, name: str) -> Any:
            value = object.__getattribute__(self, name)
            if not name.startswith("_"):
                seen = object.__getattribute__(self, "_seen")
                if seen is not None and not callable(value):
                    seen[object.__getattribute__(self, "_label") + name] = value
            return value


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


class LineStation(_Recorded):
    """One address of the line: `address`, `live` ("ok", "missing", "phantom", "none"), `fault`
    (LineFault or None), and the analyser's counters under the names the status document gives
    them (lost, syncs, repeats, repeats_max, illegals, diagnostics, docs/profibus.md "Line
    statistics"): as attributes (`station.repeats`) and in `counters`, in the daemon's table
    order when the station was read from a daemon. `wait_until()` waits for its counters."""

    def __init__(self, address: int, live: str, fault: LineFault | None,
                 counters: Mapping[str, int], connection: Connection | None = None) -> None:
        self.address = address
        self.live = live
        self.fault = fault
        self.counters: dict[str, int] = dict(counters)
        self._connection = connection

    @classmethod
    def from_status(cls, entry: Mapping[str, Any], order: Sequence[str] = (),
                    connection: Connection | None = None) -> LineStation:
        """A station of the document's `stations` list: every number but the address is a
        counter, the names of `order` first in that order."""
        f = entry.get("fault")
        fault = None if f is None else LineFault(str(f["kind"]), int(f["remaining"]),
                                                 int(f["every"]), int(f["remaining_ms"]))
        found = {k: int(v) for k, v in entry.items() if k != "address" and _counter(v)}
        counters = {k: found[k] for k in order if k in found}
        counters.update(found)
        return cls(int(entry["address"]), str(entry.get("live", "none")), fault, counters,
                   connection)

    def __getattr__(self, name: str) -> int:
        counters: dict[str, int] = self.__dict__.get("counters", {})
        if name in counters:
            seen = self._seen
            if seen is not None:
                seen[self._label + name] = counters[name]
            return counters[name]
        raise AttributeError("line station %s has no counter %r (counters: %s)"
                             % (self.__dict__.get("address", "?"), name,
                                ", ".join(counters) or "none in the status document"))

    def describe(self) -> str:
        """One line: "station 3 (ok): lost 0, syncs 1, ..., fault corrupt (2 left, every 1)"."""
        counters = ", ".join("%s %d" % kv for kv in self.counters.items())
        text = "station %d (%s): %s" % (self.address, self.live, counters or "no counters")
        f = self.fault
        if f is not None:
            left = ("%d ms left" % f.remaining_ms) if f.remaining_ms else ("%d left" % f.remaining)
            text += "; fault %s (%s, every %d)" % (f.kind, left, f.every)
        return text

    def wait_until(self, predicate: Callable[[LineStation], T], timeout: float = 5.0) -> T:
        """Reads the station again (GET /api/v1/status) and calls `predicate(station)` until it
        returns something true, and returns that: `line.station(3).wait_until(lambda s:
        s.illegals >= 5)`. After `timeout` seconds it raises WaitTimeout naming each counter
        the predicate read with its last value (`illegals=4`) and the station's counters."""
        if self._connection is None:
            raise RuntimeError("this LineStation was not read from a daemon: use "
                               "daemon.line.station(%d).wait_until()" % self.address)
        connection = self._connection
        return _wait_reading(lambda: connection.line.station(self.address), predicate, timeout,
                             "line station %d: " % self.address)

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


R = TypeVar("R", bound=_Recorded)


def _wait_reading(read: Callable[[], R], predicate: Callable[[R], T], timeout: float,
                  what: str) -> T:
    """The wait_until() of the line and of a station: `read()` anew until `predicate` of it is
    true; the timeout's message names what the predicate read and describes the last one."""
    last: list[R] = []

    def evaluate(seen: dict[str, object]) -> T:
        value = read()
        last[:] = [value]
        value._record(seen, "")
        try:
            return predicate(value)
        finally:
            value._record(None, "")

    return poll_until(evaluate, timeout, what + describe_predicate(predicate), repr,
                      lambda: last[0].describe() if last else "nothing read")


@dataclass(frozen=True)
class Line(_Recorded):
    """The line when it was read (read `daemon.line` again for newer figures, or wait for them
    with `wait_until()`): `baud` (bit/s);
    on a line in time (`master.baud`) the measured `bus_cycle_us` (the rotations that
    parameterized no station) and `parameterization_cycle_us` (those that did: the start-up, a
    station lost or parameterized again; docs/daemon.md "Statistics of the steady line"), the
    requests the master
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
    parameterization_cycle_us: BusCycle | None = None

    @classmethod
    def from_status(cls, line: Mapping[str, Any], connection: Connection | None = None) -> Line:
        """The `line` object of GET /api/v1/status (docs/daemon.md "HTTP face")."""
        def times(key: str) -> BusCycle | None:
            c = line.get(key)
            return None if c is None else BusCycle(int(c["last"]), int(c["min"]), int(c["mean"]),
                                                   int(c["max"]), int(c["cycles"]))
        cycle = times("bus_cycle_us")
        live = line.get("live_list", {})

        def addresses(state: str) -> tuple[int, ...]:
            return tuple(int(a) for a in live.get(state, ()))

        def optional(key: str) -> int | None:
            return None if line.get(key) is None else int(line[key])

        order = connection.register_map.line_counters if connection is not None else ()
        return cls(int(line["baud"]), cycle, optional("retries"), optional("gap_polls"),
                   LiveList(addresses("ok"), addresses("missing"), addresses("phantom")),
                   tuple(LineStation.from_status(s, order, connection)
                         for s in line.get("stations", ())),
                   int(line.get("illegals_unattributed", 0)),
                   int(line.get("noise_remaining_ms", 0)), connection,
                   times("parameterization_cycle_us"))

    def station(self, address: int) -> LineStation:
        """The station at this DP address; one the line never saw nor configured has live
        "none" and every counter 0."""
        # Read past the recording: a wait's message names what the predicate read, not this.
        stations: tuple[LineStation, ...] = object.__getattribute__(self, "stations")
        found = next((s for s in stations if s.address == address), None)
        if found is None:
            names = stations[0].counters if stations else {}
            found = LineStation(address, "none", None, {name: 0 for name in names},
                                object.__getattribute__(self, "connection"))
        seen = self._seen
        if seen is not None:  # wait_until(): what the predicate reads of it, by station
            found._record(seen, "station(%d)." % address)
        return found

    @property
    def configured(self) -> tuple[int, ...]:
        """The DP addresses of the stations configured on the line (the live list's ok and
        missing ones, and every gateway and slave the daemon's map names), ascending."""
        addresses = set(self.live_list.ok) | set(self.live_list.missing)
        addresses |= {s.address for s in self.stations if s.live in ("ok", "missing")}
        if self.connection is not None:
            rm = self.connection.register_map
            addresses |= {g.dp_address for g in rm.gateways} | {s.dp_address for s in rm.slaves}
        return tuple(sorted(addresses))

    def describe(self) -> str:
        """The line in a few lines: baud rate, bus cycle, live list, each station's counters and
        fault, what no station was blamed for, the noise (times in the unit that reads)."""
        head = "line: %d bit/s" % self.baud
        c = self.bus_cycle_us
        if c is not None:
            head += ", bus cycle %s (min %s, mean %s, max %s over %d cycles)" % (
                duration_text(c.last), duration_text(c.min), duration_text(c.mean),
                duration_text(c.max), c.cycles)
        if self.retries is not None:
            head += ", %d retries" % self.retries
        if self.gap_polls is not None:
            head += ", %d GAP polls" % self.gap_polls

        def listed(addresses: tuple[int, ...]) -> str:
            return ", ".join(str(a) for a in addresses) or "none"

        lines = [head, "  live list: ok %s; missing %s; phantom %s" % (
            listed(self.live_list.ok), listed(self.live_list.missing),
            listed(self.live_list.phantom))]
        lines += ["  " + s.describe() for s in self.stations]
        lines.append("  illegal telegrams no station was blamed for: %d; noise: %s" % (
            self.illegals_unattributed,
            "%d ms left" % self.noise_remaining_ms if self.noise_remaining_ms else "none"))
        return "\n".join(lines)

    def wait_until(self, predicate: Callable[[Line], T], timeout: float = 5.0) -> T:
        """Reads the line again (`daemon.line`) and calls `predicate(line)` until it returns
        something true, and returns that: `line.wait_until(lambda li: li.station(3).illegals
        >= 5)`. After `timeout` seconds it raises WaitTimeout naming what the predicate read
        with its last value (`station(3).illegals=4`, `noise_remaining_ms=0`) and the whole
        line (describe())."""
        connection = self._connection()
        return _wait_reading(lambda: connection.line, predicate, timeout, "line: ")

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
        Written to the Modbus line fault registers of unit `address` in one request; an address
        that is no station of the line raises ValueError naming the stations first."""
        connection = self._connection()
        rm = connection.register_map
        stations = self.configured
        if stations and address not in stations:
            raise ValueError("no station %d on the line (stations: %s)"
                             % (address, ", ".join(str(a) for a in stations)))
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
