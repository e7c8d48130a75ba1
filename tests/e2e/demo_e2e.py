#!/usr/bin/python3
"""End-to-end test of the out-of-the-box demo (issue 6) through Modbus only.

candp2d runs config/demo.json (its built-in default; here on free ports): a gateway at DP address 3
whose output slot Q 0..4 carries REGID commands to the Unitek drive axis1 (CAN 0x201) and whose
input slot I 0..5 receives its replies (0x181). The PLC side is Debian's pymodbus only:

  1. enable the drive          MODE 0x51 = 0x0000 (bit 2 clear)          Unitek manual, example 2
  2. ramp 1000 ms per 100 %    ACC 0x35 = 1000                           example 6
  3. read speed every 20 ms    0x3D 0x30 0x14 (cyclic read of 0x30)      example 10
  4. 30 % speed                0x31 = 9830 (32767 = 100 %)               example 11

and then reads a rising actual speed (REGID 0x30 replies in I 0..5) that settles at the set point
within the ramp time (30 % of 1000 ms = 300 ms) plus a bounded margin.
Holding register r = Q bytes 2r (high) and 2r+1 (low); input registers likewise (emulator-spec §8).
"""

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time

from pymodbus.client import ModbusTcpClient  # python3-pymodbus

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UNIT = 3
SET_POINT = 9830  # 30 % of 32767 (Unitek DE §7.1: ±32767 = ±100 %)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_port(port, proc, timeout=10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise SystemExit("FAIL: candp2d exited with %s" % proc.returncode)
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.02)
    raise SystemExit("FAIL: candp2d did not listen on %d" % port)


def tx_frames(client):
    """Status block 8210..8211: CAN frames the gateway sent (docs/modbus.md)."""
    r = client.read_input_registers(8210, 2, slave=UNIT).registers
    return (r[0] << 16) | r[1]


def command(client, regid, value=0):
    """Writes a 5-byte REGID command (REGID + 32-bit little-endian value) to Q 0..4 and waits
    until the gateway has sent it (its Tx counter moves: the slot sends on change)."""
    b = [regid] + list(value.to_bytes(4, "little", signed=True)) + [0]
    regs = [(b[0] << 8) | b[1], (b[2] << 8) | b[3], (b[4] << 8) | b[5]]
    before = tx_frames(client)
    rr = client.write_registers(0, regs, slave=UNIT)
    assert not rr.isError(), rr
    end = time.monotonic() + 5
    while tx_frames(client) == before:
        assert time.monotonic() < end, "command %02X never reached the bus" % regid
        time.sleep(0.005)


def reply(client):
    """I 0..5 as bytes: REGID, data little-endian, stuff byte."""
    rr = client.read_input_registers(0, 3, slave=UNIT)
    assert not rr.isError(), rr
    return b"".join(r.to_bytes(2, "big") for r in rr.registers)


def speed_actual(client):
    r = reply(client)
    if r[0] != 0x30:
        return None
    return int.from_bytes(r[1:3], "little", signed=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="candp2-demo-")
    proc = None
    try:
        with open(os.path.join(ROOT, "config", "demo.json")) as f:
            cfg = json.load(f)
        mb, sc = free_port(), free_port()
        cfg["modbus"]["listen"] = "127.0.0.1:%d" % mb
        cfg["http"]["listen"] = "127.0.0.1:0"  # the demo's 8080 may be taken
        for bus in cfg["buses"].values():
            if "socketcand" in bus:
                bus["socketcand"] = "127.0.0.1:%d" % sc
        path = os.path.join(tmp, "demo.json")
        with open(path, "w") as f:
            json.dump(cfg, f)
        log = open(os.path.join(tmp, "candp2d.log"), "w")
        proc = subprocess.Popen([args.candp2d, "--config", path], stdout=log,
                                stderr=subprocess.STDOUT)
        wait_for_port(mb, proc)
        client = ModbusTcpClient("127.0.0.1", port=mb, timeout=3)
        assert client.connect()
        # The gateway reaches Data_Exch within a few cycles (input register 8192 = 2).
        end = time.monotonic() + 10
        while client.read_input_registers(8192, 1, slave=UNIT).registers[0] != 2:
            assert time.monotonic() < end, "gateway never reached Data_Exch"
            time.sleep(0.02)
        command(client, 0x51, 0)       # enable
        command(client, 0x35, 1000)    # ACC: 1000 ms for 100 %
        command(client, 0x3D, 0x1430)  # 3D 30 14: speed actual every 20 ms
        end = time.monotonic() + 5
        while speed_actual(client) is None:
            assert time.monotonic() < end, "no speed replies: %s" % reply(client).hex()
            time.sleep(0.01)
        assert speed_actual(client) == 0, "drive turns before a set point"
        start = time.monotonic()
        command(client, 0x31, SET_POINT)
        samples = []
        while time.monotonic() - start < 3.0:
            v = speed_actual(client)
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
        print("settled at %d after %.3f s" % (SET_POINT, settle))
        print("1 passed, 0 failed")
        return 0
    finally:
        if proc and proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
