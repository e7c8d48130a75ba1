"""A simulated Unitek drive of candp2d (docs/drive-simulator.md): its state as the HTTP face
shows it, and the faults of its Modbus fault registers (docs/faults.md "Drive faults")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from .errors import Candp2Error

if TYPE_CHECKING:
    from .connection import Connection


@dataclass(frozen=True)
class DriveState:
    """What the drive shows now: `enabled`, the control `mode` ("speed", ...), `speed` and
    `position` actual values (speed: 32767 = 100 %), the status word `status` (REGID 0x40)."""

    enabled: bool
    mode: str
    speed: int
    position: int
    status: int


class Drive:
    """One simulated drive by name; get it with `daemon.drive(name)`.

    The fault methods need the drive's Modbus unit (`modbus_unit` in the configuration; a
    `candp2.Daemon` gives every drive one)."""

    def __init__(self, connection: Connection, name: str) -> None:
        self.connection = connection
        self.name = name
        self.config = connection.register_map.drive(name)

    def __repr__(self) -> str:
        return "<Drive %s>" % self.name

    def _http(self) -> Mapping[str, Any]:
        for d in self.connection.http_status().get("drives", []):
            if d.get("name") == self.name:
                drive: Mapping[str, Any] = d
                return drive
        raise Candp2Error("the HTTP face shows no drive %r" % self.name)

    @property
    def state(self) -> DriveState:
        """The drive's state now (from the HTTP face)."""
        d = self._http()
        return DriveState(bool(d["enabled"]), str(d["mode"]), int(d["speed"]),
                          int(d["position"]), int(d["status"]))

    @property
    def speed(self) -> int:
        """The actual speed (32767 = 100 %)."""
        return self.state.speed

    def _write(self, register: str, value: int) -> None:
        if self.config is None or self.config.unit is None:
            raise Candp2Error("drive %r has no Modbus unit (modbus_unit in its configuration)"
                              % self.name)
        self.connection.modbus.write_register(
            self.connection.register_map.drive_registers[register], value, self.config.unit)

    def mute(self, muted: bool = True) -> None:
        """The drive stops answering (True) or answers again (False)."""
        self._write("mute", 1 if muted else 0)

    def error_bits(self, bits: int) -> None:
        """Sets ERR_BITMAP1 (REGID 0x8F) error bits 0..15; any bit drops "ready"."""
        self._write("error_bits", bits)

    def warning_bits(self, bits: int) -> None:
        """Sets ERR_BITMAP1 warning bits 16..31 (given as 0..0xFFFF)."""
        self._write("warning_bits", bits)

    def restart(self) -> None:
        """The drive restarts: its power-on state, cyclic requests lost."""
        self._write("restart", 1)
