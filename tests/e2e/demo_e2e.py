"""End-to-end test of the out-of-the-box demo through Modbus only, on the candp2
package (pytest; ctest e2e_demo).

candp2d runs config/demo.json (its built-in default; here on free ports): a gateway at DP address 3
whose output slot Q 0..4 carries REGID commands to the Unitek drive axis1 (CAN 0x201) and whose
input slot I 0..5 receives its replies (0x181). The PLC side is Modbus only (the package's
Gateway: its output and input image and its Tx counter):

  1. enable the drive          MODE 0x51 = 0x0000 (bit 2 clear)          Unitek manual, example 2
  2. ramp 1000 ms per 100 %    ACC 0x35 = 1000                           example 6
  3. read speed every 20 ms    0x3D 0x30 0x14 (cyclic read of 0x30)      example 10
  4. 30 % speed                0x31 = 9830 (32767 = 100 %)               example 11

and then reads a rising actual speed (REGID 0x30 replies in I 0..5) that settles at the set point
within the ramp time (30 % of 1000 ms = 300 ms) plus a bounded margin.
"""

import json
import os
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UNIT = 3
SET_POINT = 9830  # 30 % of 32767 (Unitek DE §7.1: ±32767 = ±100 %)


def command(gw, regid, value=0):
    """Writes a 5-byte REGID command (REGID + 32-bit little-endian value) to Q 0..4 and waits
    until the gateway has sent it (its Tx counter moves: the slot sends on change)."""
    before = gw.counters.tx_frames
    gw.outputs[0:5] = bytes([regid]) + value.to_bytes(4, "little", signed=True)
    gw.wait_until(lambda g: g.counters.tx_frames != before, timeout=5)


def speed_actual(gw):
    """I 0..5: REGID, data little-endian, stuff byte; the speed when REGID is 0x30."""
    r = gw.inputs[0:6]
    if r[0] != 0x30:
        return None
    return int.from_bytes(r[1:3], "little", signed=True)


def test_demo_ramps_to_30_percent(candp2d):
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        daemon = candp2d(json.load(f))
    gw = daemon.gateway(UNIT)
    # The gateway reaches Data_Exch within a few cycles.
    gw.wait_until(lambda g: g.state == "Data_Exch", timeout=10)
    command(gw, 0x51, 0)       # enable
    command(gw, 0x35, 1000)    # ACC: 1000 ms for 100 %
    command(gw, 0x3D, 0x1430)  # 3D 30 14: speed actual every 20 ms
    gw.wait_until(lambda g: speed_actual(g) is not None, timeout=5)
    assert speed_actual(gw) == 0, "drive turns before a set point"
    start = time.monotonic()
    command(gw, 0x31, SET_POINT)
    samples = []
    while time.monotonic() - start < 3.0:
        v = speed_actual(gw)
        if v is not None:
            samples.append((time.monotonic() - start, v))
            if v == SET_POINT:
                break
        time.sleep(0.01)
    values = [v for _, v in samples]
    print("speed samples:", values)
    assert values and values[-1] == SET_POINT, "speed did not settle at %d" % SET_POINT
    assert any(0 < v < SET_POINT for v in values), "no intermediate (rising) speed seen"
    assert values == sorted(values), "speed not monotonically rising: %s" % values
    settle = samples[-1][0]
    # Ramp 300 ms; allow the Modbus/DP/CAN round trips and a loaded CI machine.
    assert settle < 1.5, "settled after %.2f s, ramp is 0.3 s" % settle
    assert daemon.drive("axis1").speed == SET_POINT
    print("settled at %d after %.3f s" % (SET_POINT, settle))
