"""A PROFIBUS line of generic DP-V0 slaves alone: no CAN-DP/2 gateway, no CAN bus (docs/slaves.md
"A line of generic slaves alone").

The plant is config/slaves-line.json as candp2 ships it: two compact stations from the example
GSD gsd/CDP2C0A.GSD (8 bytes in, 8 bytes out each) under the built-in master: in1 (DP address 4)
at I 0..7 / Q 0..7, in2 (DP address 5) at I 8..15 / Q 8..15. Each slave's field side (the inputs
its sensors report, the outputs its actuators see) is on Modbus unit 100 + address. The master
exchanges data with both; in1 leaves the bus and in2 goes on; in1 comes back and is
parameterized again.

candp2.find_example() finds the file in the source checkout (config/slaves-line.json) or beside
an installed candp2d (/usr/share/candp2/examples/slaves-line.json, its GSD in
/usr/share/candp2/examples/gsd/).
"""

from typing import Callable

from candp2 import Daemon, find_example


def test_a_line_of_slaves_without_a_gateway(candp2d: Callable[..., Daemon],
                                            candp2_binary: str) -> None:
    daemon = candp2d(find_example("slaves-line.json", candp2_binary))
    assert daemon.gateways() == []
    in1, in2 = daemon.slave("in1"), daemon.slave("in2")
    for slave in (in1, in2):
        slave.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")

    # The PLC's outputs reach the slaves' actuators, their sensors' inputs the PLC.
    in1.outputs[0:8] = bytes(range(1, 9))                       # Q 0..7
    in2.outputs[8:10] = b"\xA5\x5A"                              # Q 8..9
    in1.wait_until(lambda s: s.field_outputs[0:8] == bytes(range(1, 9)))
    in2.wait_until(lambda s: s.field_outputs[0:2] == b"\xA5\x5A")
    in2.field_inputs[0:4] = bytes.fromhex("C1 C2 C3 C4")
    in2.wait_until(lambda s: s.inputs[8:12] == bytes.fromhex("C1 C2 C3 C4"))

    in1.leave_bus()                                             # its cable is pulled
    in1.wait_until(lambda s: s.state == "Wait_Prm")             # its watchdog (200 ms) expired
    in2.outputs[8] = 0x11                                       # in2 goes on
    in2.wait_until(lambda s: s.field_outputs[0] == 0x11)

    in1.return_to_bus()                                         # back: parameterized again
    in1.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
    in1.wait_until(lambda s: s.field_outputs[0:8] == bytes(range(1, 9)))
