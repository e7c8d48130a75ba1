"""A PLC-like PROFIBUS line: the CAN-DP/2 among other DP-V0 slaves (docs/slaves.md).

The plant is config/plc-line.json as candp2 ships it: gateway gw3 (DP address 3) with the
simulated Unitek drives axis1 and axis2 on a virtual CAN bus, and two generic slaves built from
the example GSD gsd/examples/CDP20C2D.GSD: io1 (address 8: 8 DI at I 100, 8 DO at Q 100,
2 AI at I 101..104) and io2 (address 9: 16 DI at I 110..111, 16 DO at Q 110..111). Each slave's
field side (the inputs its sensors report, the outputs its actuators see) is on Modbus unit
100 + address. The master exchanges data with all three; io2 leaves the bus, the gateway and
io1 go on; io2 comes back and is parameterized again.

candp2.find_example() finds the file in the source checkout (config/plc-line.json) or beside an
installed candp2d (/usr/share/candp2/examples/plc-line.json, the GSD in
/usr/share/candp2/gsd/examples/).
"""

from typing import Callable

from candp2 import Daemon, find_example

READY = bytes.fromhex("3D E2 00 00 00")    # axis1: read REGID 0xE2 (ready) once


def test_a_slave_leaves_the_bus_and_the_others_go_on(candp2d: Callable[..., Daemon],
                                                     candp2_binary: str) -> None:
    daemon = candp2d(find_example("plc-line.json", candp2_binary))
    gw, io1, io2 = daemon.gateway("gw3"), daemon.slave("io1"), daemon.slave("io2")
    can0 = daemon.bus("can0")
    for station in (gw, io1, io2):
        station.wait_until(lambda s: s.state == "Data_Exch")

    # The PLC's outputs reach io1's actuators, its sensors' inputs the PLC.
    io1.outputs[100] = 0xA5                                   # Q 100: 8 DO
    io1.wait_until(lambda s: s.field_outputs[0] == 0xA5)
    io1.field_inputs[0:5] = bytes.fromhex("3C 12 34 56 78")    # 8 DI, 2 AI
    io1.wait_until(lambda s: s.inputs[100:105] == bytes.fromhex("3C 12 34 56 78"))

    io2.leave_bus()                                           # its cable is pulled
    io2.wait_until(lambda s: s.master_state != "Data_Exch")   # the master misses it
    io2.wait_until(lambda s: s.state == "Wait_Prm")           # its watchdog (200 ms) expired

    gw.outputs[0:5] = READY                                   # the gateway goes on ...
    can0.expect(0x201, READY)
    gw.wait_until(lambda g: g.inputs[0:6] == bytes.fromhex("E2 01 00 00 00 00"))
    io1.outputs[100] = 0x5A                                   # ... and so does io1
    io1.wait_until(lambda s: s.field_outputs[0] == 0x5A)

    io2.return_to_bus()                                       # back: parameterized again
    io2.wait_until(lambda s: s.state == "Data_Exch" and s.master_state == "Data_Exch")
    io2.outputs[110:112] = b"\x12\x34"                        # Q 110..111: 16 DO
    io2.wait_until(lambda s: s.field_outputs[0:2] == b"\x12\x34")
