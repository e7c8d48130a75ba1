#!/usr/bin/python3
"""End-to-end test of candp2d, driven from outside by independent clients.

The running daemon (manual §5.1.4 slot example on a virtual bus exported over socketcand) is
driven by mbpoll and Debian's pymodbus writing outputs and reading inputs, and by python-can
(interface="socketcand") observing the resulting CAN frames and injecting Rx frames: the round trip
byte-swapped as form byte B8 says (emulator-spec §4: a b c d e f -> b a f e d c). Bad Modbus
requests get the right exception (emulator-spec §8) and the daemon serves on; bad configurations
are rejected with the file and the JSON path; SIGHUP reopens the CAN log; SIGTERM stops cleanly.

Run by ctest (label e2e) with Debian's /usr/bin/python3:
    /usr/bin/python3 tests/e2e/daemon_e2e.py --candp2d build/bin/candp2d
Every wait is bounded; the daemon is always killed, whatever happens.
"""

import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest

import can  # python3-can
from pymodbus.client import ModbusTcpClient  # python3-pymodbus
from can_expect import expect_frame  # tests/e2e/can_expect.py (the script's folder)

CANDP2D = None  # set from the command line
MBPOLL = "/usr/bin/mbpoll"
WAIT = 10.0  # seconds: upper bound for anything that should happen within a few cycles
UNIT = 5  # unit ID = DP address of the gateway (emulator-spec §8)


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_port(port, proc, timeout=WAIT):
    """Polls until 127.0.0.1:port accepts a connection (bounded); fails if the daemon died."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise AssertionError("candp2d exited with %s before listening" % proc.returncode)
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.02)
    raise AssertionError("candp2d did not listen on port %d within %.0f s" % (port, timeout))


def read(path):
    with open(path) as f:
        return f.read()


def eventually(check, timeout=WAIT):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.01)
    return check()


def manual_514_config(modbus_port, socketcand_port, can_log):
    return {
        "_comment": "manual §5.1.4: input I 172..177 from 0x289, output Q 172..177 to 0x309, form B8",
        "modbus": {"listen": "127.0.0.1:%d" % modbus_port},
        "master": {"address": 1, "cycle_ms": 2, "retry_ms": 100},
        "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:%d" % socketcand_port}},
        "gateways": [{
            "name": "gw5", "address": UNIT, "bus": "can0",
            "parameters": {"can_bitrate": "125k", "watchdog_ms": 500},
            "slots": [
                {"io": "input", "address": 172, "length": 6, "consistent": True,
                 "comment": "02,89,B8"},
                {"io": "output", "address": 172, "length": 6, "consistent": True,
                 "comment": "03,09,B8"},
            ],
        }],
        "log": {"level": "debug", "can_log": can_log},
    }


def mbpoll(*args):
    """Runs mbpoll once against the daemon (TCP, PDU addressing); returns (rc, output)."""
    cmd = [MBPOLL, "-m", "tcp", "-p", str(Daemon.modbus_port), "-0", "-1", "-o", "2"]
    cmd += [str(a) for a in args]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=WAIT)
    return r.returncode, r.stdout + r.stderr


def mbpoll_read(table, address, count):
    """Reads `count` registers with mbpoll; returns {address: value}."""
    rc, out = mbpoll("-a", UNIT, "-t", "%d:hex" % table, "-r", address, "-c", count, "127.0.0.1")
    if rc != 0:
        raise AssertionError("mbpoll read failed (%d): %s" % (rc, out))
    return {int(a): int(v, 16) for a, v in re.findall(r"\[(\d+)\]:\s+0x([0-9A-Fa-f]+)", out)}


class Daemon:
    """The one candp2d under test (started once for the whole run)."""
    proc = None
    tmp = None
    modbus_port = None
    socketcand_port = None
    log_path = None
    log_file = None
    can_log = None

    @classmethod
    def start(cls):
        cls.tmp = tempfile.mkdtemp(prefix="candp2-e2e-")
        cls.modbus_port = free_port()
        cls.socketcand_port = free_port()
        while cls.socketcand_port == cls.modbus_port:
            cls.socketcand_port = free_port()
        cls.can_log = os.path.join(cls.tmp, "can.log")
        config = os.path.join(cls.tmp, "candp2d.json")
        with open(config, "w") as f:
            json.dump(manual_514_config(cls.modbus_port, cls.socketcand_port, cls.can_log), f)
        cls.log_path = os.path.join(cls.tmp, "candp2d.log")
        cls.log_file = open(cls.log_path, "w")
        cls.proc = subprocess.Popen([CANDP2D, "--config", config], stdout=cls.log_file,
                                    stderr=subprocess.STDOUT)
        wait_for_port(cls.modbus_port, cls.proc)
        wait_for_port(cls.socketcand_port, cls.proc)

    @classmethod
    def log(cls):
        return read(cls.log_path)

    @classmethod
    def kill(cls):
        if cls.proc and cls.proc.poll() is None:
            cls.proc.kill()
            cls.proc.wait(timeout=WAIT)
        if cls.log_file:
            cls.log_file.close()
            cls.log_file = None
        if cls.tmp:
            if os.environ.get("CANDP2_E2E_KEEP"):
                print("kept", cls.tmp, file=sys.stderr)
            else:
                shutil.rmtree(cls.tmp, ignore_errors=True)
            cls.tmp = None


def status(client, offset=0, count=1):
    rr = client.read_input_registers(8192 + offset, count, slave=UNIT)
    assert not rr.isError(), rr
    return rr.registers


class DaemonE2E(unittest.TestCase):
    """Tests run in name order against one daemon; each leaves it serving."""

    @classmethod
    def setUpClass(cls):
        Daemon.start()
        cls.pymodbus = ModbusTcpClient("127.0.0.1", port=Daemon.modbus_port, timeout=3)
        assert cls.pymodbus.connect(), "pymodbus cannot connect"
        # The master parameterizes the gateway: DP state 2 (Data_Exch), master state 4 and at
        # least one Data_Exchange (status block, docs/modbus.md).
        ok = eventually(lambda: (lambda s: s[0] == 2 and s[12] == 4 and s[29] > 0)(
            status(cls.pymodbus, 0, 37)))
        assert ok, "gateway not in Data_Exch:\n" + Daemon.log()
        cls.bus = can.Bus(interface="socketcand", host="127.0.0.1", port=Daemon.socketcand_port,
                          channel="can0")

    @classmethod
    def tearDownClass(cls):
        cls.pymodbus.close()
        cls.bus.shutdown()

    def expect_frame(self, arbitration_id, data):
        """Waits for the frame on the bus (other frames may pass first)."""
        expect_frame(self.bus, arbitration_id, data, WAIT)

    def test_1_mbpoll_write_is_sent_byte_swapped(self):
        # Q 172..177 = holding registers 86..88; form B8 swaps bytes 1-2 and 3-6 (manual §5.2.2).
        rc, out = mbpoll("-a", UNIT, "-t", "4:hex", "-r", 86, "127.0.0.1",
                         "0x0A0B", "0x0C0D", "0x0E0F")
        self.assertEqual(rc, 0, out)
        self.expect_frame(0x309, bytes.fromhex("0B0A0F0E0D0C"))
        # The holding registers read back what was written.
        self.assertEqual(mbpoll_read(4, 86, 3), {86: 0x0A0B, 87: 0x0C0D, 88: 0x0E0F})

    def test_2_pymodbus_write_is_sent_byte_swapped(self):
        rr = self.pymodbus.write_registers(86, [0x1122, 0x3344, 0x5566], slave=UNIT)
        self.assertFalse(rr.isError(), rr)
        self.expect_frame(0x309, bytes.fromhex("221166554433"))

    def test_3_injected_rx_frame_reaches_the_input_image(self):
        # 0x289 carries b a f e d c; the gateway swaps it back: I 172..177 = 0A 0B 0C 0D 0E 0F.
        self.bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("0B0A0F0E0D0C"),
                                  is_extended_id=False))
        expected = [0x0A0B, 0x0C0D, 0x0E0F]
        got = eventually(lambda: (lambda rr: not rr.isError() and rr.registers == expected)(
            self.pymodbus.read_input_registers(86, 3, slave=UNIT)))
        self.assertTrue(got, self.pymodbus.read_input_registers(86, 3, slave=UNIT))
        self.assertEqual(mbpoll_read(3, 86, 3), {86: 0x0A0B, 87: 0x0C0D, 88: 0x0E0F})
        # The same bytes as discrete inputs: I 172 = 0x0A -> inputs 1377 and 1379 set.
        rr = self.pymodbus.read_discrete_inputs(1376, 8, slave=UNIT)
        self.assertEqual(rr.bits[:8], [False, True, False, True, False, False, False, False])

    def test_4_bad_requests_get_the_right_exception(self):
        # emulator-spec §8: outside the tables 0x02, unknown unit ID 0x0B; 0 and 255 = first gateway.
        rr = self.pymodbus.read_holding_registers(4096, 1, slave=UNIT)
        self.assertTrue(rr.isError())
        self.assertEqual(rr.exception_code, 0x02)
        rr = self.pymodbus.read_input_registers(8192 + 66, 1, slave=UNIT)  # past the status block
        self.assertEqual(rr.exception_code, 0x02)
        rr = self.pymodbus.read_holding_registers(0, 1, slave=9)
        self.assertTrue(rr.isError())
        self.assertEqual(rr.exception_code, 0x0B)
        rr = self.pymodbus.write_register(8192, 7, slave=UNIT)
        self.assertEqual(rr.exception_code, 0x03)
        for unit in (0, 255):
            rr = self.pymodbus.read_input_registers(8192 + 34, 1, slave=unit)
            self.assertEqual(rr.registers, [UNIT])
        rc, out = mbpoll("-a", 9, "-t", 4, "-r", 0, "127.0.0.1")
        self.assertNotEqual(rc, 0)
        self.assertIn("Target device failed to respond", out)
        rc, out = mbpoll("-a", UNIT, "-t", 4, "-r", 5000, "127.0.0.1")
        self.assertIn("Illegal data address", out)
        # A client that sends garbage is dropped; the daemon serves on.
        with socket.create_connection(("127.0.0.1", Daemon.modbus_port), timeout=WAIT) as s:
            s.sendall(b"GET / HTTP/1.0\r\n\r\n")
            self.assertEqual(s.recv(16), b"")
        rr = self.pymodbus.read_input_registers(8192, 1, slave=UNIT)
        self.assertEqual(rr.registers, [2])
        self.assertIsNone(Daemon.proc.poll())

    def test_5_sighup_reopens_the_can_log(self):
        rotated = Daemon.can_log + ".1"
        os.rename(Daemon.can_log, rotated)
        Daemon.proc.send_signal(signal.SIGHUP)
        self.assertTrue(eventually(lambda: "CAN log reopened" in Daemon.log()), Daemon.log())
        self.assertTrue(os.path.exists(Daemon.can_log))
        rr = self.pymodbus.write_registers(86, [0x0102, 0x0304, 0x0506], slave=UNIT)
        self.assertFalse(rr.isError())
        self.expect_frame(0x309, bytes.fromhex("020106050403"))
        # candump -l notation: "(seconds.micros) can0 309#...".
        line = r"^\(\d+\.\d{6}\) can0 309#020106050403$"
        self.assertTrue(eventually(lambda: re.search(line, read(Daemon.can_log), re.M)))
        old = read(rotated)
        self.assertRegex(old, r"(?m)^\(\d+\.\d{6}\) can0 309#0B0A0F0E0D0C$")
        self.assertRegex(old, r"(?m)^\(\d+\.\d{6}\) can0 289#0B0A0F0E0D0C$")

    def test_6_frames_are_hex_dumped_at_debug_level(self):
        log = Daemon.log()
        self.assertRegex(log, r"debug \[gw5\] tx 309#0B0A0F0E0D0C")
        self.assertRegex(log, r"debug \[gw5\] rx 289#0B0A0F0E0D0C")
        self.assertRegex(log, r"info  \[master\] slave 5: Check_Diag -> Data_Exch")

    def test_9_sigterm_stops_cleanly(self):
        Daemon.proc.send_signal(signal.SIGTERM)
        self.assertEqual(Daemon.proc.wait(timeout=WAIT), 0)
        self.assertIn("[candp2d] stopped", Daemon.log())


class BadConfigurations(unittest.TestCase):
    """issue 5: missing key, wrong type, unknown bus, slot comment with odd hex: rejected with the
    file and the JSON path, exit status 2, by --check and by a normal start alike."""

    def run_config(self, mutate, *extra):
        config = manual_514_config(1502, 29536, "can.log")
        mutate(config)
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump(config, f)
        try:
            r = subprocess.run([CANDP2D, "--config", f.name] + list(extra), capture_output=True,
                               text=True, timeout=WAIT)
            return r.returncode, r.stderr, f.name
        finally:
            os.unlink(f.name)

    def check(self, mutate, path, message):
        for extra in (["--check"], []):
            rc, err, name = self.run_config(mutate, *extra)
            self.assertEqual(rc, 2, err)
            self.assertIn("candp2d: error: %s: %s: " % (name, path), err)
            self.assertIn(message, err)

    def test_missing_key(self):
        self.check(lambda c: c["gateways"][0].pop("slots"), "$.gateways[0]",
                   'missing key "slots"')

    def test_wrong_type(self):
        self.check(lambda c: c["gateways"][0]["slots"][1].update(length="six"),
                   "$.gateways[0].slots[1].length", "expected a number from 1 to 64")

    def test_unknown_bus(self):
        self.check(lambda c: c["gateways"][0].update(bus="can9"), "$.gateways[0].bus",
                   'unknown bus "can9"')

    def test_slot_comment_with_odd_hex(self):
        self.check(lambda c: c["gateways"][0]["slots"][0].update(comment="02,89,B"),
                   "$.gateways[0].slots[0].comment", "expected hex bytes like \"02,89,B8\"")

    def test_builtin_default_without_config(self):
        # No --config: the built-in default (config/demo.json) is checked / mapped.
        r = subprocess.run([CANDP2D, "--check"], capture_output=True, text=True, timeout=WAIT)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("<built-in default>: configuration OK (1 gateway(s)", r.stdout)
        r = subprocess.run([CANDP2D, "--print-modbus-map"], capture_output=True, text=True,
                           timeout=WAIT)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("Modbus/TCP 127.0.0.1:1502", r.stdout)
        self.assertIn("gw3", r.stdout)

    def test_valid_configuration_passes_check(self):
        rc, err, _ = self.run_config(lambda c: None, "--check")
        self.assertEqual(rc, 0, err)


def main():
    global CANDP2D
    parser = argparse.ArgumentParser()
    parser.add_argument("--candp2d", required=True)
    args, rest = parser.parse_known_args()
    CANDP2D = os.path.abspath(args.candp2d)
    ok = False
    try:
        program = unittest.main(argv=[sys.argv[0], "-v"] + rest, exit=False)
        ok = program.result.wasSuccessful()
    finally:
        if not ok and Daemon.log_path and os.path.exists(Daemon.log_path):
            sys.stderr.write("--- candp2d log ---\n" + Daemon.log())
        Daemon.kill()
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
