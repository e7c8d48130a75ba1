"""One generic DP-V0 slave from a GSD (docs/slaves.md) as the PLC and a test engineer see it:
the master's process image, its state and decoded diagnosis (the status block and the whole
diagnosis after it), its field side (the inputs it reports, the outputs it applies: the unit
`field_unit`) and its faults (the slave fault registers, docs/faults.md "Generic slaves")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping, Sequence, TypeVar

from .errors import Candp2Error
from .registers import DiagnosisLayout, SlaveMap, StatusValue
from .station import (ByteView, DiagnosisBytes, HexBytes, Station, bytes_to_words, hex_bytes,
                      words_to_bytes)

if TYPE_CHECKING:
    from .connection import Connection

T = TypeVar("T")

# IEC 61158-6-3 Ext_Diag_Data: a block's header byte says what it is in bits 7..6 (docs/slaves.md
# "Diagnosis"): 00 device-related and 01 identifier-related (bits 5..0 = the block's length with
# the header), 10 channel-related (bits 5..0 = the module; 3 bytes in all).
_BLOCK_TYPE_MASK = 0xC0
_BLOCK_LENGTH_MASK = 0x3F
_BLOCK_KINDS = {0x00: "device", 0x40: "identifier", 0x80: "channel"}
_CHANNEL_BLOCK_LENGTH = 3
_CHANNEL_DIRECTIONS = {0x40: "input", 0x80: "output", 0xC0: "input/output"}
_CHANNEL_ERROR_MASK = 0x1F


# ------------------------------------------------------------------------------- diagnosis

@dataclass(frozen=True)
class DiagBlock:
    """One block of Ext_Diag_Data (IEC 61158-6-3): `kind` "device" (device-related: the bytes
    a device reports, e.g. a diagnosis alarm), "identifier" (a bit per module that has
    diagnosis), "channel" (one channel's error) or "unknown" (the rest of the bytes); `raw` the
    block with its header byte, `data` the bytes after it."""

    kind: str
    raw: bytes

    @property
    def data(self) -> bytes:
        return self.raw[1:]

    @property
    def modules(self) -> tuple[int, ...]:
        """An identifier-related block: the modules whose bit is set (bit 0 of the first byte
        = module 0); () for other blocks."""
        if self.kind != "identifier":
            return ()
        return tuple(8 * i + b for i, byte in enumerate(self.data) for b in range(8)
                     if byte >> b & 1)

    @property
    def module(self) -> int | None:
        """A channel-related block: its module (header bits 5..0)."""
        return self.raw[0] & _BLOCK_LENGTH_MASK if self.kind == "channel" else None

    @property
    def channel(self) -> int | None:
        """A channel-related block: the channel number."""
        return self.data[0] & _BLOCK_LENGTH_MASK if self.kind == "channel" else None

    @property
    def direction(self) -> str | None:
        """A channel-related block: "input", "output" or "input/output"."""
        if self.kind != "channel":
            return None
        return _CHANNEL_DIRECTIONS.get(self.data[0] & _BLOCK_TYPE_MASK, "none")

    @property
    def error(self) -> int | None:
        """A channel-related block: its error type (1 short circuit, 2 undervoltage, ...)."""
        return self.data[1] & _CHANNEL_ERROR_MASK if self.kind == "channel" else None

    def __str__(self) -> str:
        if self.kind == "identifier":
            return "identifier-related: modules %s" % (
                ", ".join(str(m) for m in self.modules) or "none")
        if self.kind == "channel":
            return "channel-related: module %s, %s channel %s, error %s" % (
                self.module, self.direction, self.channel, self.error)
        return "%s-related %s" % (self.kind, hex_bytes(self.data) or "(empty)")


def decode_blocks(data: bytes) -> tuple[DiagBlock, ...]:
    """The Ext_Diag_Data blocks of `data` (the diagnosis after its 6 standard bytes). A block
    whose length runs past the end keeps what is there; a header that names no length takes
    the rest as an "unknown" block."""
    blocks: list[DiagBlock] = []
    i = 0
    while i < len(data):
        header = data[i]
        kind = _BLOCK_KINDS.get(header & _BLOCK_TYPE_MASK, "unknown")
        if kind == "channel":
            length = _CHANNEL_BLOCK_LENGTH
        elif kind == "unknown" or header & _BLOCK_LENGTH_MASK == 0:
            kind, length = "unknown", len(data) - i
        else:
            length = header & _BLOCK_LENGTH_MASK
        blocks.append(DiagBlock(kind, HexBytes(data[i:i + length])))
        i += length
    return tuple(blocks)


@dataclass(frozen=True)
class SlaveDiagnosis(DiagnosisBytes):
    """A generic slave's whole Slave_Diag answer, decoded (docs/slaves.md "Diagnosis").

    `raw` the bytes (6..244); `bits` the names of the station status bits set ("Ext_Diag",
    "Prm_Fault", "Cfg_Fault", "Station_Not_Ready", "Not_Supported", "Sync_Mode", ...);
    `master` the master holding the lock (None: none); `ident` the Ident_Number; `blocks` the
    Ext_Diag_Data after the 6 standard bytes (DiagBlock); `device` the bytes of the first
    device-related block (a diagnosis alarm), None without one. `diag[0]` is byte 0;
    `"Ext_Diag" in diag` tests a bit."""

    raw: bytes
    bits: frozenset[str]
    master: int | None
    ident: int
    blocks: tuple[DiagBlock, ...]

    @classmethod
    def decode(cls, raw: bytes, layout: DiagnosisLayout, standard: int) -> SlaveDiagnosis:
        """Decodes the bytes with the daemon's layout (RegisterMap.diagnosis); `standard` is how
        many bytes come before the Ext_Diag_Data (the master and ident bytes' end)."""
        return cls(HexBytes(raw), *cls.standard(raw, layout), decode_blocks(raw[standard:]))

    @property
    def device(self) -> bytes | None:
        """The bytes of the first device-related block (a diagnosis alarm), or None."""
        return next((b.data for b in self.blocks if b.kind == "device"), None)

    def __str__(self) -> str:
        parts = [hex_bytes(self.raw) or "(none)"]
        parts += sorted(self.bits)
        parts.append("master %s" % ("none" if self.master is None else self.master))
        parts.append("ident %04X" % self.ident)
        parts += [str(b) for b in self.blocks]
        return "; ".join(parts)


@dataclass(frozen=True)
class SlaveFaults:
    """The slave fault registers as last written (docs/faults.md "Generic slaves"): `on_bus`,
    `prm_fault` and `cfg_fault` forced, the diagnosis alarm's bytes (None: no alarm)."""

    on_bus: bool
    prm_fault: bool
    cfg_fault: bool
    alarm: bytes | None

    def __str__(self) -> str:
        parts = ["on the bus" if self.on_bus else "OFF the bus"]
        if self.prm_fault:
            parts.append("Prm fault forced")
        if self.cfg_fault:
            parts.append("Cfg fault forced")
        if self.alarm is not None:
            parts.append("alarm " + hex_bytes(self.alarm))
        return ", ".join(parts)


# ------------------------------------------------------------------------------ field side

class FieldImage(ByteView):
    """One direction of a generic slave's field side (docs/slaves.md "Field side"), on the
    slave's `field_unit`: `slave.field_inputs` (the inputs it reports, writable: what a sensor
    would put there) and `slave.field_outputs` (the outputs it applies: what an actuator would
    see). Indexed from the slave's first input / output byte like a bytes object:
    `s.field_inputs[0:2] = b"\\xA5\\x5A"`, `s.field_outputs[0]`.

    A write that starts or ends inside a register (two bytes) first reads that register, so
    its other byte keeps its value; only a user writes the field inputs, so nothing changes
    them in between."""

    def __init__(self, slave: Slave, output: bool) -> None:
        self._slave = slave
        self._output = output

    @property
    def _unit(self) -> int:
        config = self._slave.config
        if config is None or config.field_unit is None:
            raise Candp2Error("%r: slave %d has no field side (field_unit in its configuration)"
                              % (self, self._slave.address))
        if config.remote:
            raise Candp2Error("%r: slave %d is a remote station (profibus role master): its "
                              "field side is on the device" % (self, self._slave.address))
        return config.field_unit

    def __len__(self) -> int:
        config = self._slave.config
        if config is None:
            return 0
        return config.output_bytes if self._output else config.input_bytes

    def _note(self, what: str, value: T) -> T:
        return self._slave.note(self._name + what, value)

    @property
    def _name(self) -> str:
        return "field_outputs" if self._output else "field_inputs"

    @property
    def _table(self) -> str:
        m = self._slave.register_map
        return m.field_outputs if self._output else m.field_inputs

    def _registers(self, first: int, last: int) -> bytes:
        return words_to_bytes(self._slave.connection.modbus.read_registers(
            self._table, first, last - first + 1, self._unit))

    def _check(self, address: int, length: int) -> None:
        self._unit  # a slave without a field side says so, rather than "0 bytes"
        super()._check(address, length)

    def write(self, address: int, data: bytes | bytearray | Sequence[int]) -> None:
        """Writes `data` from byte `address` of the slave's inputs (field_inputs only)."""
        if self._output:
            raise TypeError("the field outputs are what the slave applies (the master's "
                            "outputs): write slave.outputs instead")
        data = bytes(data)
        self._check(address, len(data))
        if not data:
            return
        first, last = address // 2, (address + len(data) - 1) // 2
        end = address + len(data)
        words = bytearray(2 * (last - first + 1))
        if address % 2 or (end % 2 and end < len(self)):
            words = bytearray(self._registers(first, last))  # keep the neighbouring bytes
        offset = address - 2 * first
        words[offset:offset + len(data)] = data
        self._slave.connection.modbus.write_registers(first, bytes_to_words(words), self._unit)

    def __repr__(self) -> str:
        return "<%s of slave %d>" % (self._name, self._slave.address)


# ------------------------------------------------------------------------------------ slave

class Slave(Station):
    """One generic DP-V0 slave of a running candp2d (docs/slaves.md), addressed by its DP
    address (its Modbus unit ID). Get it with `daemon.slave(name_or_address)`.

    Reads go to the daemon every time (nothing is cached): `state` and `status` read the
    status block, `diagnosis` the whole diagnosis after it, `faults` the slave fault
    registers, `field_inputs` / `field_outputs` its field side. The control register
    (power_cycle(), reparameterize(), master_stop(), master_resume()) and wait_until() are
    those of every Station.

    A slave of a `profibus` line in role master is a remote device: its state and diagnosis
    are the master's view, and it has neither fault registers nor a field side."""

    kind = "slave"
    _SHOWN_AS_TEXT = (SlaveDiagnosis, SlaveFaults)

    def __init__(self, connection: Connection, address: int) -> None:
        super().__init__(connection, address)
        #: What the configuration says about this slave (None: not in the known map).
        self.config: SlaveMap | None = connection.register_map.slave(address)
        #: The slave's name in the configuration ("io1"); "slave<address>" when unknown.
        self.name = self.config.name if self.config else "slave%d" % address
        #: The inputs the slave reports (writable), on its field_unit.
        self.field_inputs = FieldImage(self, output=False)
        #: The outputs the slave applies, on its field_unit.
        self.field_outputs = FieldImage(self, output=True)

    # ---- state and diagnosis -------------------------------------------------------------

    def _read_diagnosis(self) -> SlaveDiagnosis:
        m = self.register_map
        words = self.connection.modbus.read_registers(
            m.diagnosis_bytes.table, m.diagnosis_length_register,
            m.diagnosis_bytes.first + m.diagnosis_bytes.count - m.diagnosis_length_register,
            self.address)
        length = words[0]
        data = words_to_bytes(words[m.diagnosis_bytes.first - m.diagnosis_length_register:])
        layout = m.diagnosis
        standard = max(layout.master_byte, *layout.ident_bytes) + 1
        return SlaveDiagnosis.decode(data[:length], layout, standard)

    @property
    def diagnosis(self) -> SlaveDiagnosis:
        """The Slave_Diag answer the slave would give now, all of it, decoded."""
        return self.note("diagnosis", self._read_diagnosis())

    # ---- faults (docs/faults.md "Generic slaves") ----------------------------------------

    def _fault_registers(self) -> dict[str, int]:
        if self.config is not None and self.config.remote:
            raise Candp2Error("slave %d is a remote station (profibus role master): it has no "
                              "fault registers" % self.address)
        return self.register_map.slave_faults

    def _set(self, register: str, value: int) -> None:
        self.connection.modbus.write_register(self._fault_registers()[register], value,
                                              self.address)

    def _read_faults(self) -> SlaveFaults:
        regs = self._fault_registers()
        m = self.register_map
        first = min(regs.values())
        last = m.alarm_bytes.first + m.alarm_bytes.count - 1
        words = self.connection.modbus.read_registers(m.slave_fault_table, first,
                                                      last - first + 1, self.address)

        def word(name: str) -> int:
            return words[regs[name] - first]

        n = word("alarm_length")
        alarm = words_to_bytes(words[m.alarm_bytes.first - first:])
        return SlaveFaults(word("on_bus") == 1, word("prm_fault") == 1, word("cfg_fault") == 1,
                           alarm[:n] if n else None)

    @property
    def faults(self) -> SlaveFaults:
        """The faults as set now."""
        return self.note("faults", self._read_faults())

    def leave_bus(self) -> None:
        """The slave leaves the bus (cable pulled, switched off): it answers nothing at all; its
        own time runs on, so its watchdog expires."""
        self._set("on_bus", 0)

    def return_to_bus(self) -> None:
        """The slave answers again; the master parameterizes it again."""
        self._set("on_bus", 1)

    def alarm(self, data: bytes | bytearray | Sequence[int]) -> None:
        """A diagnosis alarm: a device-related Ext_Diag_Data block with these 1..62 bytes and
        Ext_Diag set; the master learns of it from the next Data_Exchange (DH over FDL)."""
        data = bytes(data)
        m = self.register_map
        if not 1 <= len(data) <= 2 * m.alarm_bytes.count:
            raise ValueError("a diagnosis alarm has 1..%d bytes, not %d"
                             % (2 * m.alarm_bytes.count, len(data)))
        words = bytes_to_words(data + b"\0" * (len(data) % 2))
        length = self._fault_registers()["alarm_length"]
        if m.alarm_bytes.first == length + 1:  # one request: the length applies the bytes
            self.connection.modbus.write_registers(length, [len(data)] + words, self.address)
        else:
            self.connection.modbus.write_registers(m.alarm_bytes.first, words, self.address)
            self._set("alarm_length", len(data))

    def clear_alarm(self) -> None:
        """No diagnosis alarm any more."""
        self._set("alarm_length", 0)

    def force_prm_fault(self, on: bool = True) -> None:
        """At once Prm_Fault and Wait_Prm; while forced every Set_Prm is refused. False: the
        next parameterization succeeds again."""
        self._set("prm_fault", 1 if on else 0)

    def force_cfg_fault(self, on: bool = True) -> None:
        """At once Cfg_Fault and Wait_Prm; while forced every Chk_Cfg is refused. False: the
        next parameterization succeeds again."""
        self._set("cfg_fault", 1 if on else 0)

    # ---- reports ------------------------------------------------------------------------

    def describe(self) -> str:
        """The slave's state in a few lines."""
        st: Mapping[str, StatusValue] = self.status
        lines = ["slave %d (%s): %s, master %s" % (self.address, self.name,
                                                   self._named(st, "dp_state"),
                                                   self._named(st, "master_state")),
                 "  diagnosis: %s" % self._read_diagnosis()]
        if self.config is not None and not self.config.remote:
            lines.append("  faults: %s" % self._read_faults())
            if self.config.field_unit is not None:
                lines.append("  field side (unit %d): inputs %s, outputs %s" % (
                    self.config.field_unit, hex_bytes(bytes(self.field_inputs)) or "none",
                    hex_bytes(bytes(self.field_outputs)) or "none"))
        return "\n".join(lines)
