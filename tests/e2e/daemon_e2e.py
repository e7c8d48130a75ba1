"""End-to-end test of candp2d, driven from outside by independent clients (pytest, the candp2
package's plugin for the daemon; every register number from the daemon's own map).

The running daemon (manual §5.1.4 slot example on a virtual bus exported over socketcand) is driven
by mbpoll and Debian's pymodbus writing outputs and reading inputs, and by python-can (through the
socketcand export) observing the resulting CAN frames and injecting Rx frames: the round trip
byte-swapped as form byte B8 says (docs/slots.md "Data exchange in normal mode": a b c d e f -> b a
f e d c). Bad Modbus requests get the right exception (docs/modbus.md) and the daemon serves on; bad
configurations are rejected with the file and the JSON path; SIGHUP reopens the CAN log; SIGTERM
stops cleanly.

    /usr/bin/python3 -m pytest -p candp2.pytest_plugin tests/e2e/daemon_e2e.py \\
        --candp2d build/bin/candp2d          (PYTHONPATH=python; ctest e2e_candp2d)

The tests of DaemonE2E run in file order against one daemon; each leaves it serving.
"""

import json
import os
import re
import signal
import socket
import subprocess
import tempfile

import can  # python3-can
import pytest
from pymodbus.client import ModbusTcpClient  # python3-pymodbus

import candp2

MBPOLL = "/usr/bin/mbpoll"
WAIT = 10.0  # seconds: upper bound for anything that should happen within a few cycles
UNIT = 5  # unit ID = DP address of the gateway (docs/modbus.md)


def read(path):
    with open(path) as f:
        return f.read()


def manual_514_config(can_log="can.log"):
    return {
        "_comment": "manual §5.1.4: input I 172..177 from 0x289, output Q 172..177 to 0x309, "
                    "form B8",
        "modbus": {"listen": "127.0.0.1:1502"},
        "master": {"address": 1, "cycle_ms": 2, "retry_ms": 100},
        "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:29536"}},
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


@pytest.fixture(scope="module")
def daemon(candp2_binary, tmp_path_factory):
    d = candp2.Daemon(manual_514_config(str(tmp_path_factory.mktemp("e2e") / "can.log")),
                      candp2_binary)
    try:
        yield d
    finally:
        if d.returncode is None:
            d.stop(check=False)


@pytest.fixture(scope="module")
def gw(daemon):
    g = daemon.gateway(UNIT)
    # The master parameterizes the gateway: DP state Data_Exch, the master's view Data_Exch and
    # at least one Data_Exchange (status block, docs/modbus.md).
    g.wait_until(lambda g: g.state == "Data_Exch" and g.master_state == "Data_Exch"
                 and g.counters.data_exchanges > 0, timeout=WAIT)
    return g


@pytest.fixture(scope="module")
def pymodbus(daemon, gw):
    client = ModbusTcpClient(daemon.modbus_address[0], port=daemon.modbus_address[1], timeout=3)
    assert client.connect(), "pymodbus cannot connect"
    yield client
    client.close()


@pytest.fixture(scope="module")
def bus(daemon, gw):
    return daemon.bus("can0")


@pytest.fixture(scope="module")
def slots(daemon):
    """The slots' registers as the daemon's map gives them: (input slot, output slot)."""
    inp, out = daemon.register_map.gateway(UNIT).slots
    return inp, out


def mbpoll(daemon, *args):
    """Runs mbpoll once against the daemon (TCP, PDU addressing); returns (rc, output)."""
    cmd = [MBPOLL, "-m", "tcp", "-p", str(daemon.modbus_address[1]), "-0", "-1", "-o", "2"]
    cmd += [str(a) for a in args]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=WAIT)
    return r.returncode, r.stdout + r.stderr


def mbpoll_read(daemon, table, address, count):
    """Reads `count` registers with mbpoll; returns {address: value}."""
    rc, out = mbpoll(daemon, "-a", UNIT, "-t", "%d:hex" % table, "-r", address, "-c", count,
                     "127.0.0.1")
    if rc != 0:
        raise AssertionError("mbpoll read failed (%d): %s" % (rc, out))
    return {int(a): int(v, 16) for a, v in re.findall(r"\[(\d+)\]:\s+0x([0-9A-Fa-f]+)", out)}


class TestDaemonE2E:
    def test_1_mbpoll_write_is_sent_byte_swapped(self, daemon, gw, bus, slots):
        # Q 172..177 = holding registers 86..88; form B8 swaps bytes 1-2 and 3-6 (manual §5.2.2).
        first = slots[1].first_register
        rc, out = mbpoll(daemon, "-a", UNIT, "-t", "4:hex", "-r", first, "127.0.0.1",
                         "0x0A0B", "0x0C0D", "0x0E0F")
        assert rc == 0, out
        bus.expect(0x309, bytes.fromhex("0B0A0F0E0D0C"), timeout=WAIT)
        # The holding registers read back what was written.
        assert mbpoll_read(daemon, 4, first, 3) == {first: 0x0A0B, first + 1: 0x0C0D,
                                                    first + 2: 0x0E0F}

    def test_2_pymodbus_write_is_sent_byte_swapped(self, pymodbus, bus, slots):
        rr = pymodbus.write_registers(slots[1].first_register, [0x1122, 0x3344, 0x5566],
                                      slave=UNIT)
        assert not rr.isError(), rr
        bus.expect(0x309, bytes.fromhex("221166554433"), timeout=WAIT)

    def test_3_injected_rx_frame_reaches_the_input_image(self, daemon, gw, pymodbus, bus, slots):
        # 0x289 carries b a f e d c; the gateway swaps it back: I 172..177 = 0A 0B 0C 0D 0E 0F.
        bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("0B0A0F0E0D0C"),
                             is_extended_id=False))
        first = slots[0].first_register
        expected = [0x0A0B, 0x0C0D, 0x0E0F]
        gw.wait_until(lambda g: (lambda rr: not rr.isError() and rr.registers == expected)(
            pymodbus.read_input_registers(first, 3, slave=UNIT)), timeout=WAIT)
        assert mbpoll_read(daemon, 3, first, 3) == {first: 0x0A0B, first + 1: 0x0C0D,
                                                    first + 2: 0x0E0F}
        # The same bytes as discrete inputs: I 172 = 0x0A -> inputs 1377 and 1379 set.
        rr = pymodbus.read_discrete_inputs(slots[0].first_bit, 8, slave=UNIT)
        assert rr.bits[:8] == [False, True, False, True, False, False, False, False]
        # And through the package: the input image and the slot.
        assert gw.inputs[172:178] == bytes.fromhex("0A0B0C0D0E0F")
        assert gw.slot(0).data == bytes.fromhex("0A0B0C0D0E0F")

    def test_4_bad_requests_get_the_right_exception(self, daemon, gw, pymodbus):
        # docs/modbus.md: outside the tables 0x02, unknown unit ID 0x0B; 0 and 255 = first
        # gateway.
        m = daemon.register_map
        rr = pymodbus.read_holding_registers(m.outputs.first + m.outputs.count, 1, slave=UNIT)
        assert rr.isError()
        assert rr.exception_code == 0x02
        rr = pymodbus.read_input_registers(m.diagnosis_bytes.first + m.diagnosis_bytes.count, 1,
                                           slave=UNIT)
        assert rr.exception_code == 0x02  # past the status block and the whole diagnosis
        rr = pymodbus.read_holding_registers(0, 1, slave=9)
        assert rr.isError()
        assert rr.exception_code == 0x0B
        rr = pymodbus.write_register(m.control_register, max(m.commands.values()) + 3,
                                     slave=UNIT)
        assert rr.exception_code == 0x03
        for unit in m.first_gateway_units:
            rr = pymodbus.read_input_registers(m.fields["dp_address"].register, 1, slave=unit)
            assert rr.registers == [UNIT]
        rc, out = mbpoll(daemon, "-a", 9, "-t", 4, "-r", 0, "127.0.0.1")
        assert rc != 0
        assert "Target device failed to respond" in out
        rc, out = mbpoll(daemon, "-a", UNIT, "-t", 4, "-r", m.control_register - 1, "127.0.0.1")
        assert "Illegal data address" in out
        # A client that sends garbage is dropped; the daemon serves on.
        with socket.create_connection(daemon.modbus_address, timeout=WAIT) as s:
            s.sendall(b"GET / HTTP/1.0\r\n\r\n")
            assert s.recv(16) == b""
        assert gw.state == "Data_Exch"
        assert daemon.poll() is None

    def test_5_sighup_reopens_the_can_log(self, daemon, gw, pymodbus, bus, slots):
        can_log = daemon.config["log"]["can_log"]
        rotated = can_log + ".1"
        os.rename(can_log, rotated)
        daemon.signal(signal.SIGHUP)
        gw.wait_until(lambda g: "CAN log reopened" in daemon.log, timeout=WAIT)
        assert os.path.exists(can_log)
        rr = pymodbus.write_registers(slots[1].first_register, [0x0102, 0x0304, 0x0506],
                                      slave=UNIT)
        assert not rr.isError()
        bus.expect(0x309, bytes.fromhex("020106050403"), timeout=WAIT)
        # candump -l notation: "(seconds.micros) can0 309#...".
        line = r"^\(\d+\.\d{6}\) can0 309#020106050403$"
        gw.wait_until(lambda g: re.search(line, read(can_log), re.M), timeout=WAIT)
        old = read(rotated)
        assert re.search(r"(?m)^\(\d+\.\d{6}\) can0 309#0B0A0F0E0D0C$", old), old
        assert re.search(r"(?m)^\(\d+\.\d{6}\) can0 289#0B0A0F0E0D0C$", old), old

    def test_6_frames_are_hex_dumped_at_debug_level(self, daemon):
        log = daemon.log
        assert re.search(r"debug \[gw5\] tx 309#0B0A0F0E0D0C", log)
        assert re.search(r"debug \[gw5\] rx 289#0B0A0F0E0D0C", log)
        assert re.search(r"info  \[master\] slave 5: Check_Diag -> Data_Exch", log)

    def test_9_sigterm_stops_cleanly(self, daemon):
        assert daemon.stop(timeout=WAIT) == 0
        assert "[candp2d] stopped" in daemon.log


class TestBadConfigurations:
    """Missing key, wrong type, unknown bus, slot comment with odd hex: rejected with the
    file and the JSON path, exit status 2, by --check, by a normal start and by candp2.Daemon
    alike."""

    def run_config(self, binary, mutate, *extra):
        config = manual_514_config()
        mutate(config)
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump(config, f)
        try:
            r = subprocess.run([binary, "--config", f.name] + list(extra), capture_output=True,
                               text=True, timeout=WAIT)
            return r.returncode, r.stderr, f.name
        finally:
            os.unlink(f.name)

    def check(self, binary, mutate, path, message):
        for extra in (["--check"], []):
            rc, err, name = self.run_config(binary, mutate, *extra)
            assert rc == 2, err
            assert "candp2d: error: %s: %s: " % (name, path) in err
            assert message in err
        config = manual_514_config()
        mutate(config)
        with pytest.raises(candp2.ConfigError) as info:
            candp2.Daemon(config, binary)
        assert info.value.path == path
        assert message in info.value.message

    def test_missing_key(self, candp2_binary):
        self.check(candp2_binary, lambda c: c["gateways"][0].pop("slots"), "$.gateways[0]",
                   'missing key "slots"')

    def test_wrong_type(self, candp2_binary):
        self.check(candp2_binary, lambda c: c["gateways"][0]["slots"][1].update(length="six"),
                   "$.gateways[0].slots[1].length", "expected a number from 1 to 64")

    def test_unknown_bus(self, candp2_binary):
        self.check(candp2_binary, lambda c: c["gateways"][0].update(bus="can9"),
                   "$.gateways[0].bus", 'unknown bus "can9"')

    def test_slot_comment_with_odd_hex(self, candp2_binary):
        self.check(candp2_binary,
                   lambda c: c["gateways"][0]["slots"][0].update(comment="02,89,B"),
                   "$.gateways[0].slots[0].comment", "expected hex bytes like \"02,89,B8\"")

    def test_builtin_default_without_config(self, candp2_binary):
        # No --config: the built-in default (config/demo.json) is checked / mapped.
        r = subprocess.run([candp2_binary, "--check"], capture_output=True, text=True,
                           timeout=WAIT)
        assert r.returncode == 0, r.stderr
        assert "<built-in default>: configuration OK (1 gateway(s)" in r.stdout
        r = subprocess.run([candp2_binary, "--print-modbus-map"], capture_output=True, text=True,
                           timeout=WAIT)
        assert r.returncode == 0, r.stderr
        assert "Modbus/TCP 127.0.0.1:1502" in r.stdout
        assert "gw3" in r.stdout
        r = subprocess.run([candp2_binary, "--print-modbus-map", "--json"], capture_output=True,
                           text=True, timeout=WAIT)
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        assert doc["listen"] == "127.0.0.1:1502" and doc["gateways"][0]["name"] == "gw3"

    def test_valid_configuration_passes_check(self, candp2_binary):
        rc, err, _ = self.run_config(candp2_binary, lambda c: None, "--check")
        assert rc == 0, err
