"""candp2.Gateway: the image, the status block decoded, slots, faults, wait_until()."""

import json
import re
from typing import Callable

import pytest
from can.message import Message

from candp2 import CfgFault, Daemon, ModbusError, WaitTimeout

from plants import MANUAL_514

Factory = Callable[..., Daemon]


def test_image_writes_are_exact(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    gw.outputs[100:106] = b"\x01\x02\x03\x04\x05\x06"        # registers (even, even)
    gw.outputs[101:104] = b"\xAA\xBB\xCC"                    # coils: odd start
    gw.outputs[105] = 0x77                                  # one byte
    assert gw.outputs[100:106] == b"\x01\xAA\xBB\xCC\x05\x77"
    assert gw.outputs[105] == 0x77 and gw.outputs[-1] == 0
    assert len(gw.outputs) == daemon.register_map.image_bytes
    with pytest.raises(ValueError):
        gw.outputs[0:2] = b"\x01"
    with pytest.raises(IndexError):
        gw.outputs.write(len(gw.outputs) - 1, b"\x01\x02")
    with pytest.raises(TypeError):
        gw.inputs[0:1] = b"\x01"


def test_state_diagnosis_leds_counters(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    d = gw.diagnosis
    assert d.master == 1 and d.ident == 0x04A4 and "WD_On" in d
    assert d.can_state == "ok" and d.cfg_fault is None and len(d) == 11
    assert gw.master_state == "Data_Exch" and gw.bus_state == "ok"
    assert gw.leds.D == "on" and gw.leds.E == "off" and gw.leds.C == "on"
    assert gw.counters.data_exchanges > 0 and gw.counters.parameterizations == 1
    assert gw.parameters["can_diagnosis"] is True and gw.parameters["accepted"] is True
    assert "gateway 5 (gw5): Data_Exch" in gw.describe()


def test_cfg_fault_is_decoded(candp2d: Factory) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["gateways"][0]["slots"][1]["cfg_hex"] = "83 88 03 09 B8"  # 9 data bytes for 6
    for key in ("io", "length", "comment"):
        del config["gateways"][0]["slots"][1][key]
    gw = candp2d(config).gateway(5)
    gw.wait_until(lambda g: g.diagnosis.cfg_fault is not None)
    assert gw.diagnosis.cfg_fault == CfgFault(slot=1, code=3)  # code 3: wrong length
    assert "Cfg_Fault" in gw.diagnosis and gw.diagnosis.can_state is None
    assert gw.state != "Data_Exch"
    assert gw.leds.D == "off"


def test_slots_from_the_map_and_the_http_face(candp2d: Factory) -> None:
    gw = candp2d(MANUAL_514).gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
    slot = gw.slot(1)
    assert (slot.io, slot.plc, slot.can_id, slot.form) == ("output", "Q172", 0x309, 0xB8)
    assert bytes(slot) == bytes.fromhex("0A0B0C0D0E0F")
    assert slot.description == ("slot 1: output Q172..177 (6 bytes) to CAN 0x309, form B8, "
                                "comment 03,09,B8")
    assert [s.index for s in gw.slots()] == [0, 1]
    with pytest.raises(KeyError, match="no slot 7"):
        gw.slot(7)


def test_wait_until_says_what_it_last_saw(candp2d: Factory) -> None:
    gw = candp2d(MANUAL_514).gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    with pytest.raises(WaitTimeout) as info:
        gw.wait_until(lambda g: g.state == "Wait_Cfg" and g.inputs[172:174] == b"\xff\xff",
                      timeout=0.3)
    text = str(info.value)
    assert "lambda g: g.state == \"Wait_Cfg\"" in text
    assert "not true within 0.3 s; last saw state='Data_Exch'" in text
    assert "gateway 5 (gw5): Data_Exch" in text and "diagnosis: 00 0C" in text
    with pytest.raises(WaitTimeout, match=r"last saw inputs\[172:174\]=\[00 00\]"):
        gw.wait_until(lambda g: g.inputs[172:174] == b"\xff\xff", timeout=0.2)


def test_faults_over_the_control_and_fault_registers(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    can0 = daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    # drop_rx: the next frames the gateway would receive are lost, counted in IRQ_LOST.
    gw.drop_rx(1)
    can0.send(_frame(0x289, "0B0A0F0E0D0C"))
    gw.wait_until(lambda g: g.counters.irq_lost == 1)
    assert gw.diagnosis.irq_lost == 1 and gw.inputs[172:178] == bytes(6)
    can0.send(_frame(0x289, "0B0A0F0E0D0C"))
    gw.wait_until(lambda g: g.inputs[172:178] == bytes.fromhex("0A0B0C0D0E0F"))
    # warning / error-passive keep the traffic.
    gw.force_can_state("warning")
    gw.wait_until(lambda g: g.diagnosis.can_state == "warning" and g.leds.C == "morse W")
    gw.force_can_state("error-passive")
    gw.wait_until(lambda g: g.leds.C == "morse E")
    gw.force_can_state(None)
    with pytest.raises(ValueError, match="'bus-off'"):
        gw.force_can_state("off")
    # The master stops (watchdog 500 ms: Wait_Prm), resumes; re-parameterization; power cycle.
    gw.master_stop()
    gw.wait_until(lambda g: g.state == "Wait_Prm" and g.leds.E == "3 flashes")
    gw.master_resume()
    gw.wait_until(lambda g: g.state == "Data_Exch")
    before = gw.counters.parameterizations
    gw.reparameterize()
    gw.wait_until(lambda g: g.counters.parameterizations > before and g.state == "Data_Exch")
    before = gw.counters.parameterizations
    assert gw.counters.rx_frames == 1
    gw.power_cycle()                            # the gateway's counters restart at 0
    gw.wait_until(lambda g: g.counters.parameterizations > before and g.state == "Data_Exch")
    assert gw.counters.rx_frames == 0
    # A unit that is no gateway: the daemon's exception, by its name.
    with pytest.raises(ModbusError, match=r"exception 0x0B \(gateway target device failed"):
        daemon.gateway(9).state


def _frame(can_id: int, data: str) -> Message:
    return Message(arbitration_id=can_id, data=bytes.fromhex(data), is_extended_id=False)


def test_odd_byte_boundaries_in_the_description(candp2d: Factory) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["gateways"][0]["slots"].append({"io": "output", "address": 3, "length": 2,
                                           "comment": "03,0A,00"})
    gw = candp2d(config).gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.outputs[3:5] = b"\x12\x34"
    assert re.match(r"slot 2: output Q3\.\.4 \(2 bytes\) to CAN 0x30A", gw.slot(2).description)
    assert gw.outputs[2:6] == b"\x00\x12\x34\x00"
