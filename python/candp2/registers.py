"""The Modbus map of a candp2d, read from `candp2d --print-modbus-map --json`.

This module knows no register number: every number comes from the JSON the daemon prints from
its own constants (docs/modbus.md "The map as JSON"). `RegisterMap.from_binary()` runs the
binary; `RegisterMap(document)` takes an already parsed document.
"""

from __future__ import annotations

import json
import os
import subprocess
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from .errors import Candp2Error, ConfigError

#: The document format this package reads (`format`, `version` of the JSON).
FORMAT = "candp2-modbus-map"
VERSION = 1

#: A station's line fault registers, in their order from the first: written in one request, the
#: fault takes effect with its kind (docs/modbus.md "Line block").
LINE_FAULT_FIELDS = ("kind", "count", "every", "for_ms")

#: The line block's fault registers (docs/modbus.md "Line block") where the daemon's map has no
#: `line` (a line without statistics, where a line fault is refused anyway): holding registers of
#: a station's line fault and of the line's noise, and the fault kinds by their code. The map's
#: `line.faults` object replaces it (the same shape).
_LINE_FAULTS_FALLBACK: Mapping[str, Any] = {
    "table": "holding_registers",
    "registers": [{"name": name, "register": 8400 + i}
                  for i, name in enumerate(LINE_FAULT_FIELDS + ("noise_for_ms",))],
    "kinds": [{"name": name, "value": i}
              for i, name in enumerate(("none", "corrupt", "silent", "late", "double_address"))],
}

#: A status value: a number, or for the diagnosis the 11 register values.
StatusValue = int | tuple[int, ...]


@dataclass(frozen=True)
class Range:
    """A Modbus table range: `table` ("holding_registers", "input_registers", "coils",
    "discrete_inputs"), the first address and how many."""

    table: str
    first: int
    count: int


@dataclass(frozen=True)
class Field:
    """One field of the status block: its first register and how many it spans (1; 2 for
    32-bit values, high word first; 11 for the diagnosis)."""

    name: str
    register: int
    registers: int
    meaning: str


@dataclass(frozen=True)
class SlotMap:
    """Where one configured slot's bytes live: PLC `plc` ("I"/"Q") bytes `address` ..
    `address + length - 1`, Modbus registers `first_register` .. `last_register` of `table`,
    bits `first_bit` .. `last_bit` of `bit_table` (coils or discrete inputs)."""

    slot: int
    io: str
    plc: str
    address: int
    length: int
    comment: str
    table: str
    first_register: int
    last_register: int
    bit_table: str
    first_bit: int
    last_bit: int


@dataclass(frozen=True)
class GatewayMap:
    """A configured gateway: its names and unit IDs and its slots."""

    name: str
    dp_address: int
    units: tuple[int, ...]
    bus: str | None
    remote: bool
    slots: tuple[SlotMap, ...]


@dataclass(frozen=True)
class ImageRange:
    """Bytes of the PLC image: `address` .. `address + length - 1`."""

    address: int
    length: int


@dataclass(frozen=True)
class SlaveMap:
    """A configured generic slave (docs/slaves.md): its names and unit IDs, its field side's
    unit (None: none configured), how many input and output bytes it has, where they are in the
    master's PLC image (`inputs`, `outputs`: one ImageRange per module; empty when not
    mapped), and whether it is a remote station (profibus role master: no fault registers, no
    field side)."""

    name: str
    dp_address: int
    units: tuple[int, ...]
    field_unit: int | None
    input_bytes: int
    output_bytes: int
    inputs: tuple[ImageRange, ...]
    outputs: tuple[ImageRange, ...]
    remote: bool


@dataclass(frozen=True)
class DriveMap:
    """A configured simulated drive; `unit` is its Modbus unit ID (None: no fault registers)."""

    name: str
    bus: str
    rx_id: int
    tx_id: int
    unit: int | None


@dataclass(frozen=True)
class DiagnosisLayout:
    """The Slave_Diag bytes as the gateway fills them (manual §3.4)."""

    length: int
    bits: tuple[tuple[int, int, str], ...]  # (byte, mask, name)
    master_byte: int
    no_master: int
    ident_bytes: tuple[int, ...]
    ext_byte: int
    prm_marker: int
    prm_byte: int
    prm_expected: int
    cfg_marker: int
    cfg_slot: int
    cfg_code: int
    can_state_mask: int
    can_states: Mapping[int, str]
    irq_lost: int
    msg_lost: int


def _ints(values: Any) -> tuple[int, ...]:
    return tuple(int(v) for v in values)


class RegisterMap:
    """Every register number, value code and diagnosis bit of one candp2d configuration.

    Attributes (all read from the document): `image_bytes`, `outputs`, `inputs`,
    `output_bits`, `input_bits` (Ranges), `limits` (request size limits by name), `status`
    (Range of the status block), `fields` (status fields by name), `control_register`,
    `commands` (control commands by name), `forced_state_register`, `forced_states` (values by
    name: "real", "warning", "error-passive", "bus-off"), `drop_rx_register`,
    `drive_registers` (by name: "mute", "error_bits", "warning_bits", "restart"),
    `exceptions` (names by code), `first_gateway_units`, `values` (names of enumerated status
    values by field), `led_fields`, `led_off`, `led_on`, `morse` (letter by code),
    `diagnosis` (DiagnosisLayout), `diagnosis_length_register` and `diagnosis_bytes` (Range)
    of the whole Slave_Diag answer, `slave_faults` (a generic slave's fault registers by name:
    "on_bus", "prm_fault", "cfg_fault", "alarm_length", "alarm_bytes"), `slave_fault_table`,
    `alarm_bytes` (Range of the alarm's byte registers), `field_inputs` and `field_outputs` (the
    tables of a slave's field side), `line_fault_table`, `line_fault_registers` (by name: "kind",
    "count", "every", "for_ms", "noise_for_ms") and `line_fault_kinds` (names by code),
    `line_counters` (a line station's counters in table order),
    `can_fault_registers` (by name: "kind", "count", "every", "for_ms"), `can_fault_kinds`
    (names by code) and `can_fault_units` (the DP addresses of the gateways on a bus in time;
    all three empty where the map has no CAN fault block),
    `gateways`, `slaves`, `drives`, and `document` (the parsed JSON).
    """

    def __init__(self, document: Mapping[str, Any]) -> None:
        if document.get("format") != FORMAT or document.get("version") != VERSION:
            raise Candp2Error("not a %s version %d document (format %r, version %r): candp2d and "
                              "the candp2 package do not match"
                              % (FORMAT, VERSION, document.get("format"),
                                 document.get("version")))
        self.document = document
        image = document["image"]
        self.image_bytes = int(image["bytes"])
        self.outputs = self._range(image["outputs"])
        self.inputs = self._range(image["inputs"])
        self.output_bits = self._range(image["output_bits"])
        self.input_bits = self._range(image["input_bits"])
        self.limits: dict[str, int] = {k: int(v) for k, v in image["limits"].items()}
        status = document["status"]
        self.status = self._range(status)
        self.fields: dict[str, Field] = {
            f["name"]: Field(f["name"], int(f["register"]), int(f["registers"]), f["meaning"])
            for f in status["fields"]}
        control = document["control"]
        self.control_register = int(control["register"])
        self.commands: dict[str, int] = {c["name"]: int(c["value"]) for c in control["commands"]}
        faults = document["faults"]
        self.forced_state_register = int(faults["forced_can_state"]["register"])
        self.forced_states: dict[str, int] = {
            v["name"]: int(v["value"]) for v in faults["forced_can_state"]["values"]}
        self.drop_rx_register = int(faults["drop_rx"]["register"])
        self.drive_registers: dict[str, int] = {
            r["name"]: int(r["register"]) for r in document["drive_faults"]["registers"]}
        self.exceptions: dict[int, str] = {
            int(e["code"]): e["name"] for e in document["exceptions"]}
        self.first_gateway_units = _ints(document["first_gateway_units"])
        self.values: dict[str, tuple[str, ...]] = {
            k: tuple(v) for k, v in document["values"].items()}
        leds = document["leds"]
        self.led_fields: dict[str, str] = dict(leds["fields"])
        self.led_off = int(leds["off"])
        self.led_on = int(leds["on"])
        self.morse: dict[int, str] = {int(code): letter for letter, code in leds["morse"].items()}
        self.diagnosis = self._diagnosis(document["diagnosis"])
        whole = document["diagnosis_bytes"]
        self.diagnosis_length_register = int(whole["length_register"])
        self.diagnosis_bytes = self._range(whole)
        faults = document["slave_faults"]
        self.slave_fault_table = str(faults["table"])
        self.slave_faults: dict[str, int] = {
            r["name"]: int(r["register"]) for r in faults["registers"]}
        alarm = next(r for r in faults["registers"] if r["name"] == "alarm_bytes")
        self.alarm_bytes = Range(self.slave_fault_table, int(alarm["register"]),
                                 int(alarm["count"]))
        self.field_inputs = str(document["field"]["inputs"]["table"])
        self.field_outputs = str(document["field"]["outputs"]["table"])
        self.gateways = tuple(self._gateway(g) for g in document["gateways"])
        self.slaves = tuple(self._slave(s) for s in document["slaves"])
        line = document.get("line") or {}
        self._line_faults(line.get("faults", _LINE_FAULTS_FALLBACK))
        #: A line station's counters in the daemon's table order, empty where the map has no
        #: line block (docs/profibus.md "Line statistics").
        self.line_counters: tuple[str, ...] = tuple(str(c["name"])
                                                    for c in line.get("counters", ()))
        self.drives = tuple(DriveMap(d["name"], d["bus"], int(d["rx_id"]), int(d["tx_id"]),
                                     None if d["unit"] is None else int(d["unit"]))
                            for d in document["drives"])
        # docs/modbus.md "CAN fault block": only where a gateway is on a bus in time.
        can = document.get("can_faults") or {}
        self.can_fault_registers: dict[str, int] = {
            r["name"]: int(r["register"]) for r in can.get("registers", ())}
        self.can_fault_kinds: tuple[str, ...] = tuple(
            name for _, name in sorted((int(k["value"]), str(k["name"]))
                                       for k in can.get("kinds", ())))
        self.can_fault_units: tuple[int, ...] = tuple(int(u) for u in can.get("units", ()))

    def _line_faults(self, j: Mapping[str, Any]) -> None:
        self.line_fault_table = str(j["table"])
        self.line_fault_registers: dict[str, int] = {
            r["name"]: int(r["register"]) for r in j["registers"]}
        kinds = sorted((int(k["value"]), str(k["name"])) for k in j["kinds"])
        if [v for v, _ in kinds] != list(range(len(kinds))):
            raise Candp2Error("line fault kinds %r are not numbered 0.." % kinds)
        self.line_fault_kinds = tuple(name for _, name in kinds)
        first = self.line_fault_registers["kind"]
        if [self.line_fault_registers[n] for n in LINE_FAULT_FIELDS] != \
                list(range(first, first + len(LINE_FAULT_FIELDS))):
            raise Candp2Error("line fault registers %r do not follow each other in the order %s"
                              % (self.line_fault_registers, ", ".join(LINE_FAULT_FIELDS)))

    @staticmethod
    def _range(j: Mapping[str, Any]) -> Range:
        return Range(j["table"], int(j["first"]), int(j["count"]))

    @staticmethod
    def _gateway(g: Mapping[str, Any]) -> GatewayMap:
        slots = tuple(SlotMap(int(s["slot"]), s["io"], s["plc"], int(s["address"]),
                              int(s["length"]), s["comment"], s["registers"]["table"],
                              int(s["registers"]["first"]), int(s["registers"]["last"]),
                              s["bits"]["table"], int(s["bits"]["first"]),
                              int(s["bits"]["last"]))
                      for s in g["slots"])
        return GatewayMap(g["name"], int(g["dp_address"]), _ints(g["units"]), g["bus"],
                          bool(g["remote"]), slots)

    @staticmethod
    def _slave(s: Mapping[str, Any]) -> SlaveMap:
        def ranges(j: Any) -> tuple[ImageRange, ...]:
            return tuple(ImageRange(int(r["address"]), int(r["length"])) for r in j)

        return SlaveMap(s["name"], int(s["dp_address"]), _ints(s["units"]),
                        None if s["field_unit"] is None else int(s["field_unit"]),
                        int(s["input_bytes"]), int(s["output_bytes"]), ranges(s["inputs"]),
                        ranges(s["outputs"]), bool(s["remote"]))

    @staticmethod
    def _diagnosis(d: Mapping[str, Any]) -> DiagnosisLayout:
        ext = d["ext"]
        return DiagnosisLayout(
            length=int(d["length"]),
            bits=tuple((int(b["byte"]), int(b["mask"]), b["name"]) for b in d["bits"]),
            master_byte=int(d["master"]["byte"]), no_master=int(d["master"]["none"]),
            ident_bytes=_ints(d["ident"]["bytes"]),
            ext_byte=int(ext["byte"]),
            prm_marker=int(ext["prm_fault"]["marker"]), prm_byte=int(ext["prm_fault"]["byte"]),
            prm_expected=int(ext["prm_fault"]["expected"]),
            cfg_marker=int(ext["cfg_fault"]["marker"]), cfg_slot=int(ext["cfg_fault"]["slot"]),
            cfg_code=int(ext["cfg_fault"]["code"]),
            can_state_mask=int(ext["can_state_mask"]),
            can_states={int(s["code"]): s["name"] for s in ext["can_states"]},
            irq_lost=int(ext["irq_lost"]), msg_lost=int(ext["msg_lost"]))

    @classmethod
    def from_binary(cls, binary: str, config: str | os.PathLike[str] | None = None,
                    timeout: float = 30.0) -> RegisterMap:
        """Runs `binary --print-modbus-map --json [--config config]` and reads its output.

        Without `config` the map is that of the built-in default. Raises ConfigError when the
        daemon refuses the configuration (exit status 2), Candp2Error for anything else."""
        argv = [binary, "--print-modbus-map", "--json"]
        if config is not None:
            argv += ["--config", os.fspath(config)]
        try:
            r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
        except (OSError, subprocess.TimeoutExpired) as e:
            raise Candp2Error("%s: %s" % (" ".join(argv), e)) from e
        if r.returncode == 2:
            error = ConfigError.from_output(r.stderr, r.returncode)
            if error is not None:
                raise error
        if r.returncode != 0:
            raise Candp2Error("%s: exit status %d\n%s" % (" ".join(argv), r.returncode,
                                                          r.stderr.strip()))
        try:
            return cls(json.loads(r.stdout))
        except (ValueError, KeyError, TypeError) as e:
            raise Candp2Error("%s printed no usable map (%s); is it older than this package?"
                              % (binary, e)) from e

    def without_configuration(self) -> RegisterMap:
        """The generic tables only (no gateways, slaves or drives): for a daemon whose
        configuration is not known (`candp2.connect()`)."""
        document = dict(self.document)
        document["gateways"] = []
        document["slaves"] = []
        document["drives"] = []
        return RegisterMap(document)

    # ---- lookups -------------------------------------------------------------------------

    def gateway(self, address: int) -> GatewayMap | None:
        """The configured gateway with this DP address, or None."""
        for g in self.gateways:
            if g.dp_address == address:
                return g
        return None

    def slave(self, address: int) -> SlaveMap | None:
        """The configured generic slave with this DP address, or None."""
        for s in self.slaves:
            if s.dp_address == address:
                return s
        return None

    def drive(self, name: str) -> DriveMap | None:
        """The configured drive with this name, or None."""
        for d in self.drives:
            if d.name == name:
                return d
        return None

    def exception_name(self, code: int) -> str:
        """The name of a Modbus exception code ("illegal data address")."""
        return self.exceptions.get(code, "exception %d" % code)

    def decode_status(self, registers: Sequence[int]) -> dict[str, StatusValue]:
        """The status block's register values (from `status.first`) by field name: numbers,
        32-bit fields combined (high word first), the diagnosis as a tuple of its bytes."""
        out: dict[str, StatusValue] = {}
        base = self.status.first
        for f in self.fields.values():
            words = registers[f.register - base:f.register - base + f.registers]
            if len(words) != f.registers:
                continue
            if f.registers == 1:
                out[f.name] = words[0]
            elif f.registers == 2:
                out[f.name] = (words[0] << 16) | words[1]
            else:
                out[f.name] = tuple(words)
        return out

    @staticmethod
    def number(status: Mapping[str, StatusValue], field: str) -> int:
        """A numeric field of a decoded status block (decode_status())."""
        value = status[field]
        if not isinstance(value, int):
            raise TypeError("status field %s is not a number" % field)
        return value

    def shell(self) -> str:
        """The register numbers as POSIX shell assignments, for scripts that cannot read JSON
        (the QEMU guest scripts): STATUS_<FIELD> (first register of each status field),
        STATUS_FIRST, STATUS_COUNT, CONTROL_REGISTER, FAULT_FORCED_CAN_STATE, FAULT_DROP_RX,
        DRIVE_<REGISTER>, DIAGNOSIS_LENGTH and DIAGNOSIS_FIRST (the whole diagnosis),
        SLAVE_<REGISTER> (a generic slave's fault registers), and per configured slot
        GW<address>_SLOT<n>_FIRST / _LAST (its registers)."""
        lines = ["# candp2d --print-modbus-map --json as shell assignments (docs/python.md)",
                 "STATUS_FIRST=%d" % self.status.first, "STATUS_COUNT=%d" % self.status.count]
        lines += ["STATUS_%s=%d" % (f.name.upper(), f.register) for f in self.fields.values()]
        lines += ["CONTROL_REGISTER=%d" % self.control_register,
                  "FAULT_FORCED_CAN_STATE=%d" % self.forced_state_register,
                  "FAULT_DROP_RX=%d" % self.drop_rx_register]
        lines += ["DRIVE_%s=%d" % (name.upper(), r) for name, r in self.drive_registers.items()]
        lines += ["DIAGNOSIS_LENGTH=%d" % self.diagnosis_length_register,
                  "DIAGNOSIS_FIRST=%d" % self.diagnosis_bytes.first]
        lines += ["SLAVE_%s=%d" % (name.upper(), r) for name, r in self.slave_faults.items()]
        for g in self.gateways:
            for slot in g.slots:
                name = "GW%d_SLOT%d" % (g.dp_address, slot.slot)
                lines += ["%s_FIRST=%d" % (name, slot.first_register),
                          "%s_LAST=%d" % (name, slot.last_register)]
        return "\n".join(lines) + "\n"

    def value_name(self, field: str, value: int) -> str:
        """The name of an enumerated status value ("dp_state", 2 → "Data_Exch"); the number
        as text when the map has no name for it."""
        names = self.values.get(field, ())
        return names[value] if 0 <= value < len(names) else str(value)
