"""A fault test: the gateway's CAN controller goes bus-off (docs/faults.md).

What the real CAN-DP/2 shows (manual tables 3.3.1 and 3.4.5): diagnosis byte 8 = C0 (BUS_OFF)
with Ext_Diag, LED C flashing Morse 'O'; a bus-off controller sends nothing. Back on the bus,
the gateway sends again with the next change of its outputs.
"""

from typing import Callable

from candp2 import Daemon

PLANT = {
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{
        "name": "gw3", "address": 3, "bus": "can0",
        "parameters": {"can_bitrate": "500k", "can_diagnosis": True},
        "slots": [
            {"io": "output", "address": 0, "length": 5, "comment": "02,01,00"},  # to axis1
            {"io": "input", "address": 0, "length": 6, "comment": "01,81,00"},   # from axis1
        ],
    }],
    "drives": [{"name": "axis1", "bus": "can0", "rx_id": "0x201", "tx_id": "0x181"}],
}

READ_MODE = bytes.fromhex("3D 51 00 00 00")     # REGID 0x3D: read MODE (0x51) once
READ_STATUS = bytes.fromhex("3D 40 00 00 00")   # read the status word (0x40) once


def test_bus_off_and_back(candp2d: Callable[..., Daemon]) -> None:
    daemon = candp2d(PLANT)
    gw = daemon.gateway(3)
    can0 = daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.outputs[0:5] = READ_MODE
    can0.expect(0x201, READ_MODE)
    can0.expect(0x181)  # axis1 answers

    gw.force_can_state("bus-off")
    gw.wait_until(lambda g: g.diagnosis[8] == 0xC0)
    assert "Ext_Diag" in gw.diagnosis and gw.diagnosis.can_state == "bus-off"
    assert gw.leds.C == "morse O"

    gw.outputs[0:5] = READ_STATUS               # a change the gateway would send ...
    can0.expect_no_frame(duration=0.5)          # ... but nothing is on the bus
    assert gw.counters.tx_suppressed >= 1

    gw.force_can_state(None)                    # the real controller state again
    gw.wait_until(lambda g: g.diagnosis[8] == 0x00)
    assert gw.leds.C == "on" and "Ext_Diag" not in gw.diagnosis
    gw.outputs[0:5] = READ_MODE                 # the next change goes out
    can0.expect(0x201, READ_MODE)
    can0.expect(0x181)
