"""A running candp2d reached through its public faces: Modbus/TCP (the PLC image, the status
block, the fault registers), HTTP (slots, parameters, drives, the bus traces) and socketcand
(the CAN buses). `candp2.Daemon` is a Connection that also owns the process; `connect()`
attaches to one that runs already."""

from __future__ import annotations

import os
import time
from typing import Any, Mapping, Sequence

from ._http import HttpFace
from ._modbus import ModbusFace
from ._notify import parse_address
from .binary import find_binary
from .bus import Bus
from .drive import Drive
from .errors import Candp2Error, ModbusError, NoLine
from .gateway import Gateway
from .line import Line
from .registers import GatewayMap, RegisterMap, SlaveMap
from .slave import Slave

#: How many frames of each bus's trace a report shows.
REPORT_FRAMES = 20


def _by_name(kind: str, stations: Sequence[GatewayMap | SlaveMap], name: str) -> int:
    """The DP address of the configured gateway or slave named `name`; KeyError naming them
    all when there is none."""
    for s in stations:
        if s.name == name:
            return s.dp_address
    raise KeyError("no %s named %r (%ss: %s)" % (
        kind, name, kind, ", ".join(s.name for s in stations) or "unknown"))


class Connection:
    """The faces of one candp2d.

    `modbus` is "HOST:PORT"; `http` the HTTP face's "HOST:PORT" (None: parameters, slot
    descriptions and drive states are unavailable); `socketcand` maps bus names to the
    "HOST:PORT" of their socketcand export, or is one "HOST:PORT" serving every bus
    (`channels` maps bus names to the channel clients open, default the bus name);
    `register_map` comes from the daemon's binary."""

    def __init__(self, modbus: str, register_map: RegisterMap, http: str | None = None,
                 socketcand: str | Mapping[str, str] | None = None,
                 channels: Mapping[str, str] | None = None) -> None:
        #: time.monotonic() when the connection was made: report() shows times from here.
        self.started = time.monotonic()
        self.register_map = register_map
        self.modbus_address = parse_address(modbus)
        self.http_address = parse_address(http) if http else None
        self._any_bus = parse_address(socketcand) if isinstance(socketcand, str) else None
        self.socketcand: dict[str, tuple[str, int]] = {} if isinstance(socketcand, str) else {
            name: parse_address(a) for name, a in (socketcand or {}).items()}
        self.channels = dict(channels or {})
        self.modbus = ModbusFace(*self.modbus_address, register_map,
                                 on_failure=self._face_failed)
        self.http = HttpFace("http://%s:%d" % self.http_address) if self.http_address else None
        self._buses: list[Bus] = []

    def __repr__(self) -> str:
        address = getattr(self, "modbus_address", None)  # None: construction failed
        where = "modbus %s:%d" % address if address else "not started"
        return "<%s %s>" % (type(self).__name__, where)

    def _face_failed(self, error: ModbusError) -> None:
        """A face did not answer; a Daemon raises DaemonError with the log when it exited."""

    @property
    def http_url(self) -> str | None:
        """"http://127.0.0.1:PORT" of the HTTP face, or None."""
        return self.http.base if self.http else None

    def http_status(self) -> Mapping[str, Any]:
        """GET /api/v1/status (docs/daemon.md "HTTP face")."""
        if self.http is None:
            raise Candp2Error("no HTTP face: connect(http=\"HOST:PORT\") or http.listen")
        return self.http.status()

    @property
    def line(self) -> Line:
        """The built-in master's line (docs/profibus.md "Line statistics"): on a line in time
        (`master.baud`) or in profibus.role "master", its baud rate, bus cycle, live list and
        station counters from the HTTP face, with inject(), noise() and wait_until(). On an
        ideal line there is none: NoLine says that line faults and statistics need
        `master.baud` (`has_line` asks without raising)."""
        line = self.http_status().get("line")
        if line is None:
            raise NoLine("daemon.line: candp2d runs an ideal line%s, which has no line "
                         "statistics and takes no line faults (inject, noise): give the master a "
                         "baud rate, \"master\": {\"baud\": 1500000} (docs/profibus.md \"The "
                         "line in time\"); daemon.has_line is False here"
                         % self._ideal_line_where())
        return Line.from_status(line, self)

    @property
    def has_line(self) -> bool:
        """Whether the daemon runs a line in time (or profibus.role "master"): `daemon.line`
        answers; False on an ideal line."""
        return self.http_status().get("line") is not None

    def _ideal_line_where(self) -> str:
        """Where the ideal line comes from, for NoLine's message (a Daemon names its file)."""
        return " (no master.baud)"

    # ---- the objects a test works with ---------------------------------------------------

    def gateway(self, address: int | str) -> Gateway:
        """The gateway with this DP address (= Modbus unit ID), or by its configured name."""
        if isinstance(address, str):
            address = _by_name("gateway", self.register_map.gateways, address)
        return Gateway(self, address)

    def gateways(self) -> list[Gateway]:
        """Every configured gateway (from the HTTP face when the configuration is unknown)."""
        if self.register_map.gateways:
            return [Gateway(self, g.dp_address) for g in self.register_map.gateways]
        if self.http is None:
            return []
        return [Gateway(self, int(g["dp_address"]))
                for g in self.http_status().get("gateways", [])]

    def slave(self, address: int | str) -> Slave:
        """The generic slave (docs/slaves.md) with this DP address (= Modbus unit ID), or by
        its configured name."""
        if isinstance(address, str):
            address = _by_name("slave", self.register_map.slaves, address)
        return Slave(self, address)

    def slaves(self) -> list[Slave]:
        """Every configured generic slave (none when the configuration is unknown)."""
        return [Slave(self, s.dp_address) for s in self.register_map.slaves]

    def bus(self, name: str, timeout: float = 5.0) -> Bus:
        """A python-can bus on the socketcand export of bus `name` (closed with the
        connection); on a bus in time also its timing and CAN faults (`Bus.timing()`,
        `Bus.fault()`, docs/python.md "A bus in time")."""
        address = self.socketcand.get(name, self._any_bus)
        if address is None:
            raise KeyError("bus %r has no socketcand export (exported: %s)"
                           % (name, ", ".join(sorted(self.socketcand)) or "none"))
        host, port = address
        bus = Bus(self.channels.get(name, name), host, port, timeout=timeout,
                  explain=lambda can_id: self.who_uses(name, can_id), daemon=self, name=name)
        self._buses.append(bus)
        return bus

    def drive(self, name: str) -> Drive:
        """The simulated drive `name`."""
        if self.register_map.drives and self.register_map.drive(name) is None:
            raise KeyError("no drive named %r (drives: %s)" % (
                name, ", ".join(d.name for d in self.register_map.drives)))
        return Drive(self, name)

    # ---- reports ------------------------------------------------------------------------

    def who_uses(self, bus: str, can_id: int) -> str:
        """Which slots of the gateways on `bus` and which drives there use identifier `can_id`
        (or that none does), and what the drives on that bus are doing: the lines a failed
        `Bus.expect()` adds to its message."""
        users: list[str] = []
        for g in self.register_map.gateways:
            if g.bus != bus:
                continue
            try:
                slots = Gateway(self, g.dp_address).slots()
            except (Candp2Error, OSError, KeyError) as e:
                users.append("gateway %d (%s): slots unavailable (%s)" % (g.dp_address, g.name, e))
                continue
            users.extend("gateway %d (%s) %s" % (g.dp_address, g.name, s.description)
                         for s in slots if s.can_id == can_id)
        drives = [d for d in self.register_map.drives if d.bus == bus]
        for d in drives:
            if can_id == d.rx_id:
                users.append("drive %s receives its commands on it" % d.name)
            if can_id == d.tx_id:
                users.append("drive %s answers on it" % d.name)
        lines = (["identifier 0x%03X is used by: %s" % (can_id, "; ".join(users))] if users else
                 ["no slot and no drive on %s uses identifier 0x%03X" % (bus, can_id)])
        for d in drives:
            try:
                st = Drive(self, d.name).state
                lines.append("drive %s: %s, %s mode, speed %d, position %d, status 0x%04X"
                             % (d.name, "enabled" if st.enabled else "disabled", st.mode,
                                st.speed, st.position, st.status))
            except (Candp2Error, OSError, KeyError) as e:
                lines.append("drive %s: state unavailable (%s)" % (d.name, e))
        return "\n".join(lines)

    def report(self) -> str:
        """What a failing test wants to see: every gateway's and generic slave's state and
        decoded diagnosis (a slave's faults and field side too), the line (baud rate, bus
        cycle, live list, each station's counters and active fault) and the last frames of
        every bus (from the HTTP face's trace)."""
        parts: list[str] = []
        try:
            for g in self.gateways():
                parts.append(g.describe())
        except (Candp2Error, OSError) as e:
            parts.append("gateways: unavailable (%s)" % e)
        for s in self.slaves():
            try:
                parts.append(s.describe())
            except (Candp2Error, OSError) as e:
                parts.append("slave %d (%s): unavailable (%s)" % (s.address, s.name, e))
        if self.http is not None:
            try:
                status = self.http_status()
                line = status.get("line")
                parts.append("line: ideal (no master.baud: no line statistics)" if line is None
                             else Line.from_status(line, self).describe())
                # The daemon stamps frames with its own clock; shown as seconds since this
                # connection was made (the test's start): now here minus the frame's age there.
                since = time.monotonic() - self.started
                now_ms = float(status.get("time_ms", 0.0))
                for b in status.get("buses", []):
                    trace = b.get("trace", [])[-REPORT_FRAMES:]
                    lines = ["bus %s: last %d of %s frames (seconds since the test started)"
                             % (b["name"], len(trace), b.get("frames", "?"))]
                    for f in trace:
                        ident = ("%08X" if f.get("ext") else "%03X") % f["id"]
                        data = "R" if f.get("rtr") else str(f["data"]).replace(" ", "")
                        at = since - (now_ms - float(f["t_ms"])) / 1000.0
                        lines.append("  %+10.3f s  %s#%s" % (at, ident, data))
                    parts.append("\n".join(lines))
            except (Candp2Error, OSError) as e:
                parts.append("buses: unavailable (%s)" % e)
        return "\n".join(parts)

    def close(self) -> None:
        """Closes the Modbus connection and every bus opened through this connection."""
        for b in self._buses:
            b.shutdown()
        self._buses.clear()
        self.modbus.close()

    def __enter__(self) -> Connection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def connect(modbus: str = "127.0.0.1:1502", http: str | None = None,
            socketcand: str | Mapping[str, str] | None = None, *,
            binary: str | os.PathLike[str] | None = None,
            config: str | os.PathLike[str] | None = None) -> Connection:
    """Attaches to a candp2d that runs already (as a service, or started by someone else).

    `modbus`, `http` are "HOST:PORT"; `socketcand` one "HOST:PORT" for every bus (the channel
    opened is the bus name) or {bus name: "HOST:PORT"}. The register map comes from `binary`
    (found like `find_binary()`); give `config` (the daemon's configuration file) to know its
    gateways' slots and drives' units too."""
    exe = find_binary(binary)
    register_map = RegisterMap.from_binary(exe, config)
    if config is None:
        register_map = register_map.without_configuration()
    return Connection(modbus, register_map, http=http, socketcand=socketcand)
