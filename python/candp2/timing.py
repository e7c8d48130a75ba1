"""A CAN bus in time as the daemon measures it (docs/can-bus.md "Seen from outside"): its bit
rate, its exact load, its frames and the frames lost past full queues, and per identifier its
frames, period, jitter and queueing latency (send request to start of frame), as GET
/api/v1/status shows them under the bus. Times are in milliseconds, as in that document (the
`_ms` of each name). Faults on cue on the bus (docs/faults.md "CAN faults") go through the
Modbus CAN fault block (docs/modbus.md "CAN fault block"): `can_fault_request` builds the one
write, `Bus.fault()` sends it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from .errors import Candp2Error

#: The CAN fault registers in their order from the first: written in one request, the fault
#: takes effect with its kind (docs/modbus.md "CAN fault block").
CAN_FAULT_FIELDS = ("kind", "count", "every", "for_ms")

#: The longest fault and the highest count or period the registers hold.
_REGISTER_MAX = 0xFFFF


class NotTimed(Candp2Error, AttributeError):
    """The timing of a bus without a bit rate (an ideal bus: every frame is on every node the
    moment it is sent, nothing is measured) or a CAN fault on one (they need a bus in time)."""


@dataclass(frozen=True)
class BusLoad:
    """The exact load, %: of the last complete second of bus time and of the most loaded one."""

    last_pct: float
    max_pct: float


@dataclass(frozen=True)
class IdentifierTiming:
    """One identifier on the bus (its remote frames apart): its frames, the mean time between
    two of its starts of frame (`period_ms`), the longest period less the shortest
    (`jitter_ms`), and its frames' queueing latency, send request to start of frame: the last,
    the mean and the longest (ms)."""

    id: int
    extended: bool
    remote: bool
    frames: int
    period_ms: float
    jitter_ms: float
    latency_last_ms: float
    latency_mean_ms: float
    latency_max_ms: float

    @classmethod
    def from_status(cls, j: Mapping[str, Any]) -> IdentifierTiming:
        """An entry of the bus's `identifiers` in GET /api/v1/status."""
        latency = j["latency_ms"]
        return cls(int(j["id"]), bool(j["ext"]), bool(j["rtr"]), int(j["frames"]),
                   float(j["period_ms"]), float(j["jitter_ms"]), float(latency["last"]),
                   float(latency["mean"]), float(latency["max"]))


@dataclass(frozen=True)
class NodeCounters:
    """A node on the bus and its error confinement (docs/can-bus.md "Error confinement"): the
    transmit and receive error counters and the state they give ("ok", "warning",
    "error-passive", "bus-off", as the status document writes it)."""

    tec: int
    rec: int
    state: str


@dataclass(frozen=True)
class CanFaultInForce:
    """A CAN fault on cue in force on the bus (docs/can-bus.md "Seen from outside"), as a line
    station's `LineFault`: its `kind` ("error_frames", "unplugged", "wrong_bitrate", "noise"),
    its `node` (its name on the bus, "gw:NAME"; None for an identifier's error frames and
    noise) or identifier (`id`, `extended`; None for a node's fault and noise), the frames it
    still spoils (`remaining`, 0 with a time or until "none"), every how many (`every`) and the
    time left (`remaining_ms`, 0 with a count or until "none")."""

    kind: str
    node: str | None
    id: int | None
    extended: bool
    remaining: int
    every: int
    remaining_ms: int

    @classmethod
    def from_status(cls, j: Mapping[str, Any]) -> CanFaultInForce:
        """An entry of the bus's `faults` in GET /api/v1/status."""
        return cls(str(j["kind"]), None if j["node"] is None else str(j["node"]),
                   None if j["id"] is None else int(j["id"]), bool(j["ext"]),
                   int(j["remaining"]), int(j["every"]), int(j["remaining_ms"]))

    def describe(self) -> str:
        """One line: "unplugged gw:g5 (40 ms left)", "error_frames 181 (3 left, every 2)"."""
        what = self.node if self.node is not None else (
            ("%08X" if self.extended else "%03X") % self.id if self.id is not None else "bus")
        left = ("%d ms left" % self.remaining_ms if self.remaining_ms else
                "%d left" % self.remaining if self.remaining else "until none")
        return "%s %s (%s%s)" % (self.kind, what, left,
                                 ", every %d" % self.every if self.every > 1 else "")


@dataclass(frozen=True)
class BusTiming:
    """A bus in time when it was read: `timed_bitrate` (bit/s), `load`, `frames_on_bus`,
    `tx_lost`, and `identifiers`, the data frames' figures by identifier (`remote`: the remote
    frames', by identifier), each in the bus's order of priority; `error_frames`, the frames
    that ended in an error frame, and `nodes`, each node's counters by its name on the bus
    ("gw:NAME" for a gateway); `faults`, the CAN faults on cue in force, in the status
    document's order."""

    name: str
    timed_bitrate: int
    load: BusLoad
    frames_on_bus: int
    tx_lost: int
    identifiers: Mapping[int, IdentifierTiming] = field(default_factory=dict)
    remote: Mapping[int, IdentifierTiming] = field(default_factory=dict)
    error_frames: int = 0
    nodes: Mapping[str, NodeCounters] = field(default_factory=dict)
    faults: tuple[CanFaultInForce, ...] = ()

    @classmethod
    def from_status(cls, bus: Mapping[str, Any]) -> BusTiming:
        """A bus of GET /api/v1/status's `buses`; NotTimed for an ideal bus (it has no
        `timed_bitrate`)."""
        name = str(bus.get("name", "?"))
        if "timed_bitrate" not in bus:
            raise NotTimed("bus %s is an ideal bus: it has no timing and takes no CAN faults; "
                           "give it a bit rate, \"buses\": {\"%s\": {\"type\": \"virtual\", "
                           "\"bitrate\": \"500k\"}} (docs/can-bus.md \"The bus in time\")"
                           % (name, name))
        ids = [IdentifierTiming.from_status(i) for i in bus.get("identifiers", ())]
        return cls(name, int(bus["timed_bitrate"]),
                   BusLoad(float(bus["load"]["last_pct"]), float(bus["load"]["max_pct"])),
                   int(bus["frames_on_bus"]), int(bus["tx_lost"]),
                   {i.id: i for i in ids if not i.remote}, {i.id: i for i in ids if i.remote},
                   int(bus.get("error_frames", 0)),
                   {str(n["name"]): NodeCounters(int(n["tec"]), int(n["rec"]), str(n["state"]))
                    for n in bus.get("nodes", ())},
                   tuple(CanFaultInForce.from_status(f) for f in bus.get("faults", ())))

    def describe(self) -> str:
        """The bus in a few lines: bit rate, load, frames, lost, error frames, each identifier's
        figures, each node's counters, each fault in force."""
        lines = ["bus %s: %d bit/s, load %.1f %% (max %.1f %%), %d frames, %d lost, "
                 "%d error frames" % (self.name, self.timed_bitrate, self.load.last_pct,
                                      self.load.max_pct, self.frames_on_bus, self.tx_lost,
                                      self.error_frames)]
        for i in list(self.identifiers.values()) + list(self.remote.values()):
            lines.append("  %s%s: %d frames, period %.3f ms, jitter %.3f ms, latency last %.3f"
                         " / mean %.3f / max %.3f ms" % (
                             ("%08X" if i.extended else "%03X") % i.id, " remote" * i.remote,
                             i.frames, i.period_ms, i.jitter_ms, i.latency_last_ms,
                             i.latency_mean_ms, i.latency_max_ms))
        for name, n in self.nodes.items():
            lines.append("  node %s: TEC %d, REC %d, %s" % (name, n.tec, n.rec, n.state))
        for f in self.faults:
            lines.append("  fault %s" % f.describe())
        return "\n".join(lines)


@dataclass(frozen=True)
class CanFaultRequest:
    """One Modbus write: `values` into holding registers from `register` of `unit`."""

    unit: int
    register: int
    values: tuple[int, ...]


def can_fault_request(registers: Mapping[str, int], kinds: Sequence[str],
                      gateways: Sequence[int], bus: str, kind: str, count: int | None = None,
                      every: int = 1, for_ms: int | None = None,
                      gateway: int | None = None) -> CanFaultRequest:
    """The write of a CAN fault on `bus` (docs/modbus.md "CAN fault block"): `registers` and
    `kinds` as the daemon's map names them, `gateways` the DP addresses of the gateways on the
    bus that have the block (the map's `can_faults.units` on this bus). `gateway` picks the
    node (default: the first); noise is the whole bus's (any of them is the unit)."""
    if not gateways:
        raise NotTimed("bus %s has no gateway with a CAN fault block: CAN faults need a bus in "
                       "time with a gateway on it (docs/modbus.md \"CAN fault block\")" % bus)
    if kind not in kinds:
        raise ValueError("CAN fault kind %r: expected one of %s" % (kind, ", ".join(kinds)))
    unit = gateways[0] if gateway is None else gateway
    if unit not in gateways:
        raise ValueError("no gateway %d on bus %s (gateways: %s)"
                         % (unit, bus, ", ".join(str(g) for g in gateways)))
    if count is not None and for_ms is not None:
        raise ValueError("give count or for_ms, not both")
    if kind == "noise" and for_ms is None:
        raise ValueError("noise needs for_ms (how long)")
    for name, value in (("count", count), ("every", every), ("for_ms", for_ms)):
        if value is not None and not 1 <= value <= _REGISTER_MAX:
            raise ValueError("%s %d: expected 1..%d" % (name, value, _REGISTER_MAX))
    first = registers["kind"]
    if [registers[n] for n in CAN_FAULT_FIELDS] != list(range(first, first + 4)):
        raise Candp2Error("CAN fault registers %r do not follow each other in the order %s"
                          % (dict(registers), ", ".join(CAN_FAULT_FIELDS)))
    values = {"kind": kinds.index(kind),
              "count": 0 if for_ms is not None else (1 if count is None else count),
              "every": every, "for_ms": for_ms or 0}
    return CanFaultRequest(unit, first, tuple(values[n] for n in CAN_FAULT_FIELDS))
