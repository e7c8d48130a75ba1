"""The README's demo as a test: PLC -> gateway -> CAN -> drive -> CAN -> gateway -> PLC.

The plant is candp2d's built-in default (config/demo.json): gateway 3 on a virtual CAN bus with
the simulated Unitek drive axis1 (commands on 0x201, replies on 0x181). Output slot Q 0..4
carries one REGID command (REGID, value little-endian; form 00 sends the bytes as they are),
input slot I 0..5 shows the drive's replies.

    pytest python/examples                      # candp2d on PATH, else the build tree
    pytest python/examples --candp2d PATH -n 4  # pytest-xdist: every daemon on its own ports
"""

from typing import Callable

from candp2 import Daemon

DEMO = {
    "master": {"address": 1, "cycle_ms": 10},
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{
        "name": "gw3", "address": 3, "bus": "can0",
        "parameters": {"can_bitrate": "500k", "can_diagnosis": True, "watchdog_ms": 200},
        "slots": [
            {"io": "output", "address": 0, "length": 5, "comment": "02,01,00"},  # to axis1
            {"io": "input", "address": 0, "length": 6, "comment": "01,81,00"},   # from axis1
        ],
    }],
    "drives": [{"type": "unitek", "name": "axis1", "bus": "can0",
                "rx_id": "0x201", "tx_id": "0x181"}],
}


def test_enable_axis1_at_30_percent(candp2d: Callable[..., Daemon]) -> None:
    daemon = candp2d(DEMO)
    gw = daemon.gateway(3)
    can0 = daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")

    for command in ("51 00 00 00 00",   # MODE 0x51 = 0: enable (bit 2 "disable" clear)
                    "3D A8 64 00 00",   # read the speed 0xA8 every 100 ms (0x64)
                    "31 66 26 00 00"):  # speed set point 0x2666 = 9830 = 30 % of 32767
        gw.outputs[0:5] = bytes.fromhex(command)
        can0.expect(0x201, bytes.fromhex(command))  # each command on the bus before the next

    # I 0..5 once the ramp is done: REGID 0xA8, speed 0x2666, stuff byte.
    gw.wait_until(lambda g: g.inputs[0:6] == bytes.fromhex("A8 66 26 00 00 00"), timeout=10)
    assert daemon.drive("axis1").speed == 9830
