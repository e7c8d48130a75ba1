"""One emulated CAN-DP/2 as the PLC and a test engineer see it: the master's process image,
the gateway's state, diagnosis, LEDs and counters (the Modbus status block), its slots and
parameters (the HTTP face), and the faults a test can inject (docs/faults.md)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, Mapping

from .errors import Candp2Error
from .registers import DiagnosisLayout, RegisterMap, SlotMap, StatusValue
from .station import POLL_INTERVAL, DiagnosisBytes, HexBytes, Image, Station, hex_bytes

if TYPE_CHECKING:
    from .connection import Connection

__all__ = ["CfgFault", "Counters", "Diagnosis", "Gateway", "Image", "Led", "Leds", "POLL_INTERVAL",
           "PrmFault", "Slot", "hex_bytes"]


# ------------------------------------------------------------------------------- diagnosis

@dataclass(frozen=True)
class CfgFault:
    """The gateway rejected Chk_Cfg: the slot and the fault code (manual §3.4.2)."""

    slot: int
    code: int


@dataclass(frozen=True)
class PrmFault:
    """The gateway rejected Set_Prm: the telegram byte and the value it expected."""

    byte: int
    expected: int


@dataclass(frozen=True)
class Diagnosis(DiagnosisBytes):
    """The 11 Slave_Diag bytes, decoded (manual §3.4).

    `raw` the bytes; `bits` the names of the station status bits that are set ("Ext_Diag",
    "Cfg_Fault", "WD_On", ...); `master` the parameterizing master (None before one);
    `ident` the ident number; `cfg_fault` / `prm_fault` when bytes 8..10 report one; else
    `can_state` ("ok", "warning", "error-passive", "bus-off"), `irq_lost` and `msg_lost` as
    bytes 8..10 carry them (all zero without the CAN-Diagnosis parameter).
    `diag[8]` is byte 8; `"Ext_Diag" in diag` tests a bit.
    """

    raw: bytes
    bits: frozenset[str]
    master: int | None
    ident: int
    cfg_fault: CfgFault | None
    prm_fault: PrmFault | None
    can_state: str | None
    irq_lost: int | None
    msg_lost: int | None

    @classmethod
    def decode(cls, raw: bytes, layout: DiagnosisLayout) -> Diagnosis:
        """Decodes the bytes with the daemon's layout (RegisterMap.diagnosis)."""
        bits, master, ident = cls.standard(raw, layout)
        marker = raw[layout.ext_byte]
        cfg = prm = None
        can_state = irq = msg = None
        if marker == layout.cfg_marker:
            cfg = CfgFault(raw[layout.cfg_slot], raw[layout.cfg_code])
        elif marker == layout.prm_marker:
            prm = PrmFault(raw[layout.prm_byte], raw[layout.prm_expected])
        else:
            can_state = layout.can_states.get(marker & layout.can_state_mask)
            irq, msg = raw[layout.irq_lost], raw[layout.msg_lost]
        return cls(HexBytes(raw), bits, master, ident, cfg, prm, can_state, irq, msg)

    def __str__(self) -> str:
        parts = [hex_bytes(self.raw)]
        parts += sorted(self.bits)
        parts.append("master %s" % ("none" if self.master is None else self.master))
        parts.append("ident %04X" % self.ident)
        if self.cfg_fault:
            parts.append("Cfg fault: slot %d, code %d"
                         % (self.cfg_fault.slot, self.cfg_fault.code))
        if self.prm_fault:
            parts.append("Prm fault: byte %d, expected 0x%02X"
                         % (self.prm_fault.byte, self.prm_fault.expected))
        if self.can_state is not None:
            parts.append("CAN %s, IRQ_LOST %s, MSG_LOST %s"
                         % (self.can_state, self.irq_lost, self.msg_lost))
        return "; ".join(parts)


# ------------------------------------------------------------------------------------ LEDs

class Led:
    """One LED of manual table 3.3.1: its `text` ("on", "off", "3 flashes", "morse O") and the
    status block's `code`. Compare it with its text: `gw.leds.P == "on"`; `"flashes" in
    gw.leds.E` works too. It is not a truth value: `bool(led)` (and so `assert gw.leds.P`, which
    would pass for "off" as well) raises TypeError naming the comparison to write."""

    __slots__ = ("text", "code")

    def __init__(self, text: str, code: int) -> None:
        self.text = text
        self.code = code

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Led):
            return self.text == other.text
        if isinstance(other, str):
            return self.text == other
        return NotImplemented

    def __ne__(self, other: object) -> bool:
        equal = self.__eq__(other)
        return equal if equal is NotImplemented else not equal

    def __hash__(self) -> int:
        return hash(self.text)

    def __contains__(self, part: str) -> bool:
        return part in self.text

    def __bool__(self) -> bool:
        raise TypeError("an LED is not a truth value (it is %r): compare it with its text, "
                        "e.g. `leds.P == \"on\"`, `leds.E != \"off\"`" % self.text)

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        return "Led(%r)" % self.text


@dataclass(frozen=True)
class Leds:
    """The four LEDs of manual table 3.3.1, each a `Led` compared with its text: "on", "off",
    "3 flashes" (LED E: 3 waiting for Set_Prm, 4 for Chk_Cfg), "morse O" (LED C: W warning, E
    error passive, O bus off). `codes` holds the status block's numbers (P, D, E, C)."""

    P: Led
    D: Led
    E: Led
    C: Led
    codes: tuple[int, int, int, int]

    @classmethod
    def from_status(cls, status: Mapping[str, StatusValue], register_map: RegisterMap) -> Leds:
        def led(code: int) -> Led:
            if code == register_map.led_off:
                return Led("off", code)
            if code == register_map.led_on:
                return Led("on", code)
            if code in register_map.morse:
                return Led("morse " + register_map.morse[code], code)
            return Led("%d flashes" % code, code)

        p, d, e, c = (register_map.number(status, register_map.led_fields[name])
                      for name in "PDEC")
        return cls(led(p), led(d), led(e), led(c), (p, d, e, c))

    def __str__(self) -> str:
        return "P %s, D %s, E %s, C %s" % (self.P, self.D, self.E, self.C)


# -------------------------------------------------------------------------------- counters

@dataclass(frozen=True)
class Counters:
    """The gateway's counters from the status block (docs/modbus.md): CAN frames received and
    sent, frames lost (IRQ_LOST, MSG_LOST), Communication Window FIFO level and high water,
    Data_Exchanges answered, Set_Prm telegrams received, frames suppressed by a forced bus-off,
    socketcand reconnections, and the DP master's missed cycles (the same for every gateway)."""

    rx_frames: int
    tx_frames: int
    irq_lost: int
    msg_lost: int
    fifo_level: int
    fifo_high_water: int
    data_exchanges: int
    parameterizations: int
    tx_suppressed: int
    rx_suppressed: int
    reconnects: int
    master_cycles_missed: int

    @classmethod
    def from_status(cls, status: Mapping[str, StatusValue]) -> Counters:
        values = {f.name: RegisterMap.number(status, f.name) for f in fields(cls)}
        return cls(**values)

    def __str__(self) -> str:
        return ", ".join("%s %d" % (f.name, getattr(self, f.name)) for f in fields(self))


# ------------------------------------------------------------------------------------ slots

@dataclass(frozen=True)
class Slot:
    """One slot of the gateway: where its bytes are (`plc` "Q0", `address`, `length`), the
    bytes now (`data`), and what the gateway made of its Chk_Cfg entry (`can_id`, `extended`,
    `form`, `kind`, `frames` sent or received; None without the HTTP face)."""

    index: int
    io: str
    plc: str
    address: int
    length: int
    data: bytes
    comment: str
    can_id: int | None
    extended: bool
    form: int | None
    kind: str | None
    frames: int | None

    def __bytes__(self) -> bytes:
        return self.data

    @property
    def description(self) -> str:
        """"slot 0: output Q0..4 (5 bytes) to CAN 0x201, form 00, comment 02,01,00"."""
        text = "slot %d: %s %s%d..%d (%d bytes)" % (self.index, self.io, self.plc[0],
                                                    self.address,
                                                    self.address + self.length - 1, self.length)
        if self.can_id is not None:
            text += " %s CAN 0x%0*X" % ("to" if self.io == "output" else "from",
                                        8 if self.extended else 3, self.can_id)
        if self.form is not None:
            text += ", form %02X" % self.form
        if self.comment:
            text += ", comment " + self.comment
        return text

    def __str__(self) -> str:
        return "%s: %s" % (self.description, hex_bytes(self.data))


# ---------------------------------------------------------------------------------- gateway

class Gateway(Station):
    """One emulated gateway of a running candp2d, addressed by its DP address (which is its
    Modbus unit ID). Get it with `daemon.gateway(address)`.

    Reads go to the daemon every time (nothing is cached): `state`, `diagnosis`, `leds`,
    `counters` and `status` read the Modbus status block, `parameters` and `slot(n)` also the
    HTTP face. The control register (power_cycle(), reparameterize(), master_stop(),
    master_resume()) and wait_until() are those of every Station."""

    kind = "gateway"
    _SHOWN_AS_TEXT = (Diagnosis, Leds, Counters)

    def __init__(self, connection: Connection, address: int) -> None:
        super().__init__(connection, address)
        #: What the configuration says about this gateway (None: not in the known map).
        self.config = connection.register_map.gateway(address)
        #: The gateway's name in the configuration ("gw3"); "gw<address>" when unknown.
        self.name = self.config.name if self.config else "gw%d" % address

    # ---- the status block ----------------------------------------------------------------

    def _state(self, status: Mapping[str, StatusValue]) -> str:
        return self._named(status, "dp_state")

    @property
    def bus_state(self) -> str:
        """The CAN controller state the gateway sees: "ok", "warning", "error-passive",
        "bus-off" (a forced state included)."""
        return self.note("bus_state", self._named(self.status, "bus_state"))

    def _diagnosis(self, status: Mapping[str, StatusValue]) -> Diagnosis:
        raw = status["diag"]
        assert isinstance(raw, tuple)
        return Diagnosis.decode(bytes(raw), self.register_map.diagnosis)

    @property
    def diagnosis(self) -> Diagnosis:
        """The Slave_Diag bytes the gateway would answer now, decoded."""
        return self.note("diagnosis", self._diagnosis(self.status))

    @property
    def leds(self) -> Leds:
        """LEDs P, D, E, C (manual table 3.3.1)."""
        return self.note("leds", Leds.from_status(self.status, self.register_map))

    @property
    def counters(self) -> Counters:
        """The gateway's counters."""
        return self.note("counters", Counters.from_status(self.status))

    # ---- the HTTP face ------------------------------------------------------------------

    def _http(self) -> Mapping[str, Any]:
        status = self.connection.http_status()
        for g in status.get("gateways", []):
            if g.get("dp_address") == self.address:
                gateway: Mapping[str, Any] = g
                return gateway
        raise Candp2Error("the HTTP face shows no gateway %d" % self.address)

    @property
    def parameters(self) -> Mapping[str, Any]:
        """The Set_Prm user parameters (accepted, else configured) as the HTTP face shows them:
        "bitrate", "can_diagnosis", "watchdog_ms", "user_prm_hex", ..."""
        value: Mapping[str, Any] = self._http()["parameters"]
        return self.note("parameters", value)

    def slots(self) -> list[Slot]:
        """Every slot (see slot())."""
        indexes = sorted({s.slot for s in self.config.slots} if self.config else
                         {int(s["slot"]) for s in self._http_slots()})
        return [self.slot(i) for i in indexes]

    def _http_slots(self) -> list[Mapping[str, Any]]:
        if self.connection.http is None:
            return []
        slots: list[Mapping[str, Any]] = list(self._http().get("slots", []))
        return slots

    def slot(self, index: int) -> Slot:
        """Slot `index` (0 = the first of the configuration): its bytes and description."""
        known: SlotMap | None = None
        if self.config:
            known = next((s for s in self.config.slots if s.slot == index), None)
        http = next((s for s in self._http_slots() if s.get("slot") == index), None)
        if known is not None:
            io, plc, address, length = known.io, known.plc, known.address, known.length
            comment = known.comment
        elif http is not None and http.get("plc"):
            plc_text = str(http["plc"])
            plc, address, length = plc_text[0], int(plc_text[1:]), int(http["length"])
            io, comment = ("input" if plc == "I" else "output"), ""
        else:
            have = [s.slot for s in self.config.slots] if self.config else []
            raise KeyError("gateway %d has no slot %d (slots: %s)" % (self.address, index, have))
        data = (self.inputs if io == "input" else self.outputs).read(address, length)
        return self.note("slot(%d)" % index, Slot(
            index=index, io=io, plc="%s%d" % (plc, address), address=address, length=length,
            data=data, comment=comment,
            can_id=None if http is None or http.get("id") is None else int(http["id"]),
            extended=bool(http and http.get("extended")),
            form=None if http is None else int(http["form"]),
            kind=None if http is None else str(http["kind"]),
            frames=None if http is None else int(http["frames"])))

    # ---- faults of the CAN side (docs/faults.md) -----------------------------------------

    def force_can_state(self, state: str | None) -> None:
        """Forces the CAN controller state the gateway sees: "warning", "error-passive",
        "bus-off", or None for the real state again. Bus-off sends and receives nothing."""
        m = self.register_map
        name = "real" if state is None else state
        if name not in m.forced_states:
            raise ValueError("CAN state %r: expected one of %s or None"
                             % (state, ", ".join(repr(s) for s in m.forced_states
                                                 if s != "real")))
        self.connection.modbus.write_register(m.forced_state_register, m.forced_states[name],
                                              self.address)

    def drop_rx(self, n: int) -> None:
        """The next `n` frames the gateway would receive are lost (IRQ_LOST); 0 cancels."""
        self.connection.modbus.write_register(self.register_map.drop_rx_register, n,
                                              self.address)

    def describe(self) -> str:
        """The gateway's state in a few lines (one status block read)."""
        st = self.status
        diag = self._diagnosis(st)
        lines = [
            "gateway %d (%s): %s, master %s, CAN %s" % (
                self.address, self.name, self._state(st),
                self._named(st, "master_state"), self._named(st, "bus_state")),
            "  diagnosis: %s" % diag,
            "  LEDs: %s" % Leds.from_status(st, self.register_map),
            "  counters: %s" % Counters.from_status(st),
        ]
        return "\n".join(lines)
