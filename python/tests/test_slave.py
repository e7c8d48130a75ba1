"""candp2.Slave: a generic DP-V0 slave (docs/slaves.md) through the map, the PLC image, its
field side, its whole diagnosis decoded, its faults, the control register, wait_until()."""

import json
from pathlib import Path
from typing import Callable

import pytest

from candp2 import (Candp2Error, Connection, Daemon, DiagBlock, ModbusError, RegisterMap,
                    WaitTimeout)
from candp2.slave import decode_blocks

from plants import PLC_LINE, ROOT

Factory = Callable[..., Daemon]


def test_slaves_in_the_map_by_name_and_address(candp2d: Factory) -> None:
    # The configuration file itself: its relative GSD path ("../gsd/examples/...") is made
    # absolute for the copy the daemon runs.
    daemon = candp2d(ROOT / "config" / "plc-line.json")
    io1 = daemon.slave("io1")
    assert (io1.address, io1.name) == (8, "io1")
    assert daemon.slave(9).name == "io2"
    assert [s.name for s in daemon.slaves()] == ["io1", "io2"]
    assert io1.config is not None
    assert (io1.config.field_unit, io1.config.input_bytes, io1.config.output_bytes) == (108, 5, 1)
    assert [(r.address, r.length) for r in io1.config.inputs] == [(100, 1), (101, 4)]
    assert Path(daemon.config["slaves"][0]["gsd"]).resolve() == \
        (ROOT / "gsd" / "examples" / "CDP20C2D.GSD").resolve()
    with pytest.raises(KeyError, match="no slave named 'io3' \\(slaves: io1, io2\\)"):
        daemon.slave("io3")
    assert len(io1.field_inputs) == 5 and len(io1.field_outputs) == 1


def test_field_side_both_ways(candp2d: Factory) -> None:
    daemon = candp2d(PLC_LINE)
    io1, io2 = daemon.slave("io1"), daemon.slave("io2")
    io1.wait_until(lambda s: s.state == "Data_Exch")
    io2.wait_until(lambda s: s.state == "Data_Exch")
    # The PLC's outputs reach the field side, the field inputs the PLC's input image.
    io1.outputs[100] = 0xA5
    io2.outputs[110:112] = b"\x12\x34"
    io1.wait_until(lambda s: s.field_outputs[0] == 0xA5)
    io2.wait_until(lambda s: s.field_outputs[0:2] == b"\x12\x34")
    io1.field_inputs[0:5] = bytes.fromhex("3C 12 34 56 78")
    io1.wait_until(lambda s: s.inputs[100:105] == bytes.fromhex("3C 12 34 56 78"))
    # Writes inside a register keep its other byte (5 input bytes: 3 registers).
    io1.field_inputs[1] = 0x99
    io1.field_inputs[4] = 0x11
    io1.field_inputs[2:4] = b"\xAB\xCD"
    assert bytes(io1.field_inputs) == bytes.fromhex("3C 99 AB CD 11")
    io1.wait_until(lambda s: s.inputs[100:105] == bytes.fromhex("3C 99 AB CD 11"))
    assert bytes(io2.field_inputs) == bytes(2)  # the other slave's are its own
    with pytest.raises(TypeError, match="write slave.outputs"):
        io1.field_outputs[0] = 1
    with pytest.raises(IndexError):
        io1.field_inputs.write(4, b"\x01\x02")
    with pytest.raises(ValueError):
        io1.field_inputs[0:2] = b"\x01"


def test_whole_diagnosis_decoded_and_the_alarm(candp2d: Factory) -> None:
    io1 = candp2d(PLC_LINE).slave("io1")
    io1.wait_until(lambda s: s.state == "Data_Exch")
    d = io1.diagnosis
    assert d.raw == bytes.fromhex("00 0C 00 01 0C 2D") and len(d) == 6
    assert d.bits == {"WD_On"} and d.master == 1 and d.ident == 0x0C2D
    assert d.blocks == () and d.device is None
    # 9 bytes: the diagnosis (16 bytes) runs past the status block's 11.
    alarm = bytes(range(1, 10))
    io1.alarm(alarm)
    io1.wait_until(lambda s: s.diagnosis.device == alarm)
    d = io1.diagnosis
    assert "Ext_Diag" in d and d[6] == 1 + len(alarm) and len(d) == 16
    assert d.blocks == (DiagBlock("device", bytes([10]) + alarm),)
    assert io1.faults.alarm == alarm
    assert "device-related 01 02 03 04 05 06 07 08 09" in str(d)
    io1.alarm(b"\x42")  # an odd length, and a shorter one replaces it
    io1.wait_until(lambda s: s.diagnosis.device == b"\x42")
    io1.clear_alarm()
    io1.wait_until(lambda s: s.diagnosis.blocks == () and "Ext_Diag" not in s.diagnosis)
    faults = io1.faults
    assert faults.alarm is None
    for bad in (b"", bytes(63)):
        with pytest.raises(ValueError, match="1..62 bytes"):
            io1.alarm(bad)


def test_ext_diag_blocks_of_the_standard() -> None:
    # IEC 61158-6-3: a device-related block (header 00LLLLLL), an identifier-related one
    # (01LLLLLL: modules 0 and 9 report diagnosis), a channel-related one (10MMMMMM: module 2,
    # output channel 5, error 1 short circuit), then a header that names no length.
    blocks = decode_blocks(bytes.fromhex("03 AA BB 43 01 02 82 85 21 C0 77"))
    assert [b.kind for b in blocks] == ["device", "identifier", "channel", "unknown"]
    assert blocks[0].data == b"\xAA\xBB"
    assert blocks[1].modules == (0, 9)
    assert (blocks[2].module, blocks[2].channel, blocks[2].direction, blocks[2].error) == \
        (2, 5, "output", 1)
    assert blocks[3].raw == b"\xC0\x77"
    assert str(blocks[2]) == "channel-related: module 2, output channel 5, error 1"
    # A block cut short keeps what is there.
    assert decode_blocks(b"\x05\x01") == (DiagBlock("device", b"\x05\x01"),)


def test_leaves_the_bus_and_the_others_go_on(candp2d: Factory) -> None:
    daemon = candp2d(PLC_LINE)
    gw, io1, io2 = daemon.gateway("gw3"), daemon.slave("io1"), daemon.slave("io2")
    io2.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
    io2.leave_bus()
    assert io2.faults.on_bus is False
    # The master loses it; its own watchdog (200 ms) takes it out of Data_Exch.
    io2.wait_until(lambda s: s.master_state != "Data_Exch" and s.state == "Wait_Prm")
    exchanges = gw.counters.data_exchanges
    io1.outputs[100] = 0x5A
    io1.wait_until(lambda s: s.field_outputs[0] == 0x5A)
    gw.wait_until(lambda g: g.counters.data_exchanges > exchanges and g.state == "Data_Exch")
    io2.return_to_bus()
    io2.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
    assert io2.faults.on_bus is True


def test_forced_prm_and_cfg_faults(candp2d: Factory) -> None:
    io1 = candp2d(PLC_LINE).slave("io1")
    io1.wait_until(lambda s: s.state == "Data_Exch")
    io1.force_prm_fault()
    io1.wait_until(lambda s: "Prm_Fault" in s.diagnosis and s.state == "Wait_Prm")
    assert io1.faults.prm_fault is True
    io1.force_prm_fault(False)
    io1.wait_until(lambda s: s.state == "Data_Exch" and "Prm_Fault" not in s.diagnosis)
    io1.force_cfg_fault()
    io1.wait_until(lambda s: "Cfg_Fault" in s.diagnosis and s.state != "Data_Exch")
    faults = io1.faults
    assert faults.cfg_fault is True and faults.prm_fault is False
    io1.force_cfg_fault(False)
    io1.wait_until(lambda s: s.state == "Data_Exch" and "Cfg_Fault" not in s.diagnosis)


def test_control_register(candp2d: Factory) -> None:
    io1 = candp2d(PLC_LINE).slave("io1")
    io1.wait_until(lambda s: s.state == "Data_Exch")
    before = io1.status["parameterizations"]
    io1.reparameterize()
    io1.wait_until(lambda s: s.status["parameterizations"] != before
                   and s.state == "Data_Exch")
    io1.master_stop()  # watchdog 200 ms
    io1.wait_until(lambda s: s.state == "Wait_Prm" and s.status["addressed"] == 0)
    io1.master_resume()
    io1.wait_until(lambda s: s.state == "Data_Exch")
    io1.outputs[100] = 0x0F
    io1.wait_until(lambda s: s.field_outputs[0] == 0x0F)
    io1.power_cycle()  # the outputs go to the safe state (0) at once
    assert io1.field_outputs[0] == 0
    io1.wait_until(lambda s: s.state == "Data_Exch" and s.field_outputs[0] == 0x0F)


def test_wait_until_says_what_it_last_saw(candp2d: Factory) -> None:
    io1 = candp2d(PLC_LINE).slave("io1")
    io1.wait_until(lambda s: s.state == "Data_Exch")
    with pytest.raises(WaitTimeout) as info:
        io1.wait_until(lambda s: s.field_outputs[0:1] == b"\xff", timeout=0.3)
    text = str(info.value)
    assert "lambda s: s.field_outputs[0:1] == b\"\\xff\"" in text
    assert "last saw field_outputs[0:1]=[00]" in text
    assert "slave 8 (io1): Data_Exch, master Data_Exch" in text
    assert "diagnosis: 00 0C 00 01 0C 2D; WD_On; master 1; ident 0C2D" in text
    assert "faults: on the bus" in text and "field side (unit 108)" in text
    with pytest.raises(WaitTimeout, match="last saw diagnosis=00 0C 00 01 0C 2D; WD_On"):
        io1.wait_until(lambda s: "Ext_Diag" in s.diagnosis, timeout=0.2)


def test_a_unit_that_is_no_slave(candp2d: Factory) -> None:
    daemon = candp2d(PLC_LINE)
    with pytest.raises(ModbusError, match=r"exception 0x0B"):
        daemon.slave(20).state
    # A gateway has no slave fault registers: the daemon's exception 0x02.
    with pytest.raises(ModbusError, match=r"exception 0x02"):
        daemon.slave(3).leave_bus()


def test_remote_slaves_have_no_faults_or_field_side(candp2_binary: str, tmp_path: Path) -> None:
    """profibus role master: the slave is a remote device (docs/profibus.md); the package says
    so without asking the daemon."""
    config = json.loads(json.dumps(PLC_LINE))
    # The map does not open the line; the configuration wants a device that exists.
    config["profibus"] = {"port": "/dev/null", "baud": 19200, "role": "master"}
    del config["buses"], config["gateways"][0]["bus"]
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(config))
    m = RegisterMap.from_binary(candp2_binary, path)
    assert [s.remote for s in m.slaves] == [True, True]
    slave = Connection("127.0.0.1:1", m).slave("io1")  # nothing listens: nothing is asked
    with pytest.raises(Candp2Error, match="remote station"):
        slave.leave_bus()
    with pytest.raises(Candp2Error, match="remote station"):
        slave.field_inputs[0] = 1
