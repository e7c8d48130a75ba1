#!/usr/bin/python3
"""End-to-end test of candp2d's PROFIBUS line (emulator-spec §10) over a pseudo-terminal.

Process S runs `profibus.role: "slaves"` on `pty:<tmp>/pb` with gateway 3 (the manual §5.1.4 slots)
on a virtual CAN bus exported over socketcand. It is driven over the pty by:

  * a small FDL master written here (test code: telegrams built from emulator-spec §10's tables,
    the first telegrams byte for byte as in its capture), and
  * a second candp2d, process M, with `role: "master"` on the same pty (the link path opened as a
    serial device) driving remote gateway 3.

Shown: (a) the manual §5.1.4 round trip (outputs over FDL -> frame on S's bus; a frame injected on
S's bus -> the inputs in the Data_Exchange answer, in S's and in M's Modbus image); (b) a Cfg
fault diagnosis read over FDL (Cfg_Fault, 3E slot code); (c) watchdog expiry when the master
stops (S's status block: DP state 0 = Wait_Prm; no more CAN Tx); (d) S killed -> M's status block
shows Station_Non_Existent; S restarted on the same pty path -> M parameterizes it again. Plus: S
refuses Modbus writes to its output image with exception 0x04, M refuses a power cycle of a remote
station with exception 0x04 and re-parameterizes it on request, and both status blocks show the
line counters.

Run by ctest (label e2e) with Debian's /usr/bin/python3 (python3-pymodbus, python3-can):
    /usr/bin/python3 tests/e2e/profibus_e2e.py --candp2d build/bin/candp2d
Every wait is bounded by a deadline; the daemons are always killed.
"""

import argparse
import json
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import termios
import time
import tty
import unittest

import can  # python3-can
from pymodbus.client import ModbusTcpClient  # python3-pymodbus
from can_expect import expect_frame  # tests/e2e/can_expect.py (the script's folder)

CANDP2D = None
WAIT = 10.0  # seconds: upper bound for anything that should happen within a few cycles
STATION = 3  # the gateway's DP address
MASTER = 2   # the test master's address (emulator-spec §10 capture: class 1 master at 2)

# emulator-spec §10: SD1 0x10, SD2 0x68, SD3 0xA2, SC 0xE5, ED 0x16; SAPs of the DP services.
SD1, SD2, SD3, SC, ED = 0x10, 0x68, 0xA2, 0xE5, 0x16
SAP_DIAG, SAP_PRM, SAP_CFG, SAP_MASTER = 60, 61, 62, 62

# manual §5.1.4 slots (special identifier format, emulator-spec §2): input 6 bytes from 0x289,
# output 6 bytes to 0x309, form B8.
CFG_514 = bytes.fromhex("43 85 02 89 B8 83 85 03 09 B8")
# Output slot with 9 data bytes: wrong length (emulator-spec §2 code 3) in slot 1.
CFG_BAD = bytes.fromhex("43 85 02 89 B8 83 88 03 09 B8")
# emulator-spec §10 capture: WD on, 300 ms (30 x 1 x 10 ms), ident 04A4, GSD default user bytes.
PRM_300MS = bytes.fromhex("88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF")


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def eventually(check, timeout=WAIT):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.01)
    return check()


def fcs(data):
    return sum(data) & 0xFF  # emulator-spec §10: arithmetic sum mod 256


def sd2(da, sa, fc, du, dsap=None, ssap=None):
    body = bytes([da | (0x80 if dsap is not None else 0), sa | (0x80 if ssap is not None else 0),
                  fc])
    if dsap is not None:
        body += bytes([dsap])
    if ssap is not None:
        body += bytes([ssap])
    body += bytes(du)
    return bytes([SD2, len(body), len(body), SD2]) + body + bytes([fcs(body), ED])


class FdlMaster:
    """A minimal class 1 master on the pty link: FCB/FCV as emulator-spec §10 describes."""

    def __init__(self, path, address=MASTER):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.fd)
        self.address = address
        self.fcb = {}  # station -> FCB of the last request; absent: next is the first (FCV=0)

    def close(self):
        os.close(self.fd)

    def fdl_status(self, station):
        body = bytes([station, self.address, 0x49])  # FC 0x49: request, FDL_Status
        self.fcb.pop(station, None)
        return self.transact(bytes([SD1]) + body + bytes([fcs(body), ED]))

    def srd(self, station, du, dsap=None, ssap=SAP_MASTER):
        if station in self.fcb:
            fcb = not self.fcb[station]
            fc = 0x40 | (0x20 if fcb else 0) | 0x10 | 0x0D  # FCV=1, toggled FCB, SRD high
        else:
            fcb = True
            fc = 0x40 | 0x20 | 0x0D  # first: FCB=1, FCV=0
        self.fcb[station] = fcb
        if dsap is None:
            ssap = None
        return self.transact(sd2(station, self.address, fc, du, dsap, ssap))

    def transact(self, telegram, timeout=2.0):
        os.write(self.fd, telegram)
        return self.read_telegram(timeout)

    def read_telegram(self, timeout):
        """One response telegram as bytes, or None when nothing complete arrived in time."""
        buf = b""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            need = self.expected_length(buf)
            if need is not None and len(buf) >= need:
                return buf[:need]
            r, _, _ = select.select([self.fd], [], [], max(0.0, end - time.monotonic()))
            if r:
                try:
                    buf += os.read(self.fd, 512)
                except BlockingIOError:
                    pass
        return None

    @staticmethod
    def expected_length(buf):
        if not buf:
            return None
        if buf[0] == SC:
            return 1
        if buf[0] == SD1:
            return 6
        if buf[0] == SD3:
            return 14
        if buf[0] == SD2:
            return None if len(buf) < 2 else buf[1] + 6
        raise AssertionError("unexpected start byte %02X in %s" % (buf[0], buf.hex()))

    # DP services (emulator-spec §10 table)
    def slave_diag(self, station):
        r = self.srd(station, b"", dsap=SAP_DIAG)
        assert r and r[0] == SD2, r
        return r[9:-2]  # after 68 LE LEr 68 DA SA FC DSAP SSAP

    def set_prm(self, station, prm):
        return self.srd(station, prm, dsap=SAP_PRM)

    def chk_cfg(self, station, cfg):
        return self.srd(station, cfg, dsap=SAP_CFG)

    def data_exchange(self, station, outputs):
        r = self.srd(station, outputs)
        assert r is not None, "no answer to Data_Exchange"
        if r[0] == SC:
            return r, b""
        if r[0] == SD3:
            return r, r[4:12]
        return r, r[7:-2]

    def parameterize(self, station, prm=PRM_300MS, cfg=CFG_514):
        assert self.fdl_status(station) is not None, "no FDL_Status answer"
        self.slave_diag(station)
        assert self.set_prm(station, prm) == bytes([SC])
        assert self.chk_cfg(station, cfg) == bytes([SC])
        return self.slave_diag(station)


class Candp2d:
    def __init__(self, tmp, name, config):
        self.path = os.path.join(tmp, name + ".json")
        with open(self.path, "w") as f:
            json.dump(config, f)
        self.log_path = os.path.join(tmp, name + ".log")
        self.log_file = open(self.log_path, "w")
        self.proc = subprocess.Popen([CANDP2D, "--config", self.path], stdout=self.log_file,
                                     stderr=subprocess.STDOUT)

    def log(self):
        with open(self.log_path) as f:
            return f.read()

    def wait_for_line(self, needle, timeout=WAIT):
        ok = eventually(lambda: needle in self.log() or self.proc.poll() is not None, timeout)
        if needle not in self.log():
            raise AssertionError("no '%s' in the log of %s:\n%s" % (needle, self.path, self.log()))
        return ok

    def wait_for_port(self, port, timeout=WAIT):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                raise AssertionError("candp2d exited with %s:\n%s" % (self.proc.returncode,
                                                                      self.log()))
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                    return
            except OSError:
                time.sleep(0.02)
        raise AssertionError("candp2d did not listen on %d:\n%s" % (port, self.log()))

    def kill(self, sig=signal.SIGTERM):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=WAIT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log_file.close()


def slots_514():
    return [
        {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"},
    ]


def slaves_config(link, modbus_port, socketcand_port):
    return {
        "modbus": {"listen": "127.0.0.1:%d" % modbus_port},
        "profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
        "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:%d" % socketcand_port}},
        "gateways": [{"name": "gw3", "address": STATION, "bus": "can0", "slots": slots_514()}],
        "log": {"level": "debug"},
    }


# docs/modbus.md: the PROFIBUS line group of the status block starts at 8192 + LINE (line_role).
LINE = 43


def status(client, offset=0, count=1):
    rr = client.read_input_registers(8192 + offset, count, slave=STATION)
    assert not rr.isError(), rr
    return rr.registers


def regs_to_bytes(regs):
    out = b""
    for r in regs:
        out += bytes([r >> 8, r & 0xFF])
    return out


class SlaveSide:
    """Process S and its observers."""

    def __init__(self):
        self.tmp = tempfile.mkdtemp(prefix="candp2-pb-e2e-")
        self.link = os.path.join(self.tmp, "pb")
        self.modbus_port = free_port()
        self.socketcand_port = free_port()
        while self.socketcand_port == self.modbus_port:
            self.socketcand_port = free_port()
        self.starts = 0
        self.start()

    def start(self):
        self.starts += 1
        self.daemon = Candp2d(self.tmp, "S%d" % self.starts,
                              slaves_config(self.link, self.modbus_port, self.socketcand_port))
        self.daemon.wait_for_port(self.modbus_port)
        self.daemon.wait_for_port(self.socketcand_port)
        assert os.path.islink(self.link), "no pty link at " + self.link
        self.modbus = ModbusTcpClient("127.0.0.1", port=self.modbus_port, timeout=3)
        assert self.modbus.connect()
        self.bus = can.Bus(interface="socketcand", host="127.0.0.1", port=self.socketcand_port,
                           channel="can0")

    def stop(self, sig=signal.SIGTERM):
        if self.daemon.proc.poll() is not None and self.daemon.log_file.closed:
            return
        self.modbus.close()
        self.bus.shutdown()
        self.daemon.kill(sig)

    def close(self):
        self.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def expect_frame(self, arbitration_id, data, timeout=WAIT):
        expect_frame(self.bus, arbitration_id, data, timeout)

    def drain_bus(self):
        while self.bus.recv(timeout=0) is not None:
            pass


class TestMasterDrivesSlaves(unittest.TestCase):
    """The test's FDL master against process S."""

    @classmethod
    def setUpClass(cls):
        cls.s = SlaveSide()
        cls.master = FdlMaster(cls.s.link)

    @classmethod
    def tearDownClass(cls):
        cls.master.close()
        cls.s.close()

    def test_1_capture_bytes_of_emulator_spec_10(self):
        m = self.master
        # The capture's first telegrams byte for byte; FDL_Status answer SD1 FC 0x00 (slave, OK).
        self.assertEqual(m.transact(bytes.fromhex("10 03 02 49 4E 16")),
                         bytes([SD1, 0x02, 0x03, 0x00, 0x05, ED]))
        diag = m.transact(bytes.fromhex("68 05 05 68 83 82 6D 3C 3E EC 16"))
        self.assertIsNotNone(diag, "no Slave_Diag answer:\n" + self.s.daemon.log())
        # SD2, SAPs swapped (DSAP 62, SSAP 60), FC DL; 11 diagnosis bytes (emulator-spec §3).
        self.assertEqual(diag[:9], bytes([SD2, 16, 16, SD2, 0x82, 0x83, 0x08, 0x3E, 0x3C]))
        self.assertEqual(diag[12], 0xFF)   # byte 3: no master yet
        self.assertEqual(diag[13:15], bytes([0x04, 0xA4]))
        self.assertEqual(m.transact(bytes.fromhex(
            "68 15 15 68 83 82 5D 3D 3E 88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF 2C 16")),
            bytes([SC]))
        self.assertEqual(m.transact(bytes.fromhex(
            "68 0F 0F 68 83 82 7D 3E 3E 43 85 02 89 B8 83 85 03 09 B8 D5 16")), bytes([SC]))
        diag = m.transact(bytes.fromhex("68 05 05 68 83 82 5D 3C 3E DC 16"))
        self.assertEqual(diag[9 + 3], MASTER, diag.hex())  # parameterized by master 2
        self.assertFalse(diag[9] & 0x02, "Station_Not_Ready after parameterization")
        r = m.transact(bytes.fromhex("68 09 09 68 03 02 7D 11 22 33 44 55 66 E7 16"))
        self.assertIsNotNone(r)
        self.assertIn(r[0], (SD2, SD3, SC))
        # The output bytes go out on CAN, byte-swapped as form B8 says (emulator-spec §4).
        self.s.expect_frame(0x309, bytes.fromhex("22 11 66 55 44 33"))
        ok = eventually(lambda: status(self.s.modbus)[0] == 2)
        self.assertTrue(ok, "S's gateway not in Data_Exch:\n" + self.s.daemon.log())
        m.fcb[STATION] = True  # the capture's last Data_Exchange had FCB=1

    def test_2_round_trip_and_wire_image(self):
        m = self.master
        s = self.s
        s.drain_bus()
        m.data_exchange(STATION, bytes.fromhex("01 02 03 04 05 06"))
        s.expect_frame(0x309, bytes.fromhex("02 01 06 05 04 03"))
        # A frame injected on S's bus comes back in the Data_Exchange answer.
        s.bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("A1 A2 A3 A4 A5 A6"),
                               is_extended_id=False))
        want = bytes.fromhex("A2 A1 A6 A5 A4 A3")
        got = eventually(lambda: (lambda r: r[1] == want and r[1])(
            m.data_exchange(STATION, bytes.fromhex("01 02 03 04 05 06"))))
        self.assertEqual(got, want)
        # S's Modbus image shows the wire: Q 172..177 as received, I 172..177 as sent.
        rr = s.modbus.read_holding_registers(86, 3, slave=STATION)
        self.assertEqual(regs_to_bytes(rr.registers), bytes.fromhex("01 02 03 04 05 06"))
        rr = s.modbus.read_input_registers(86, 3, slave=STATION)
        self.assertEqual(regs_to_bytes(rr.registers), want)

    def test_3_output_image_is_read_only(self):
        rr = self.s.modbus.write_register(86, 0x1234, slave=STATION)
        self.assertTrue(rr.isError())
        self.assertEqual(rr.exception_code, 0x04)
        self.assertTrue(eventually(lambda: "exception 0x04" in self.s.daemon.log()),
                        self.s.daemon.log())

    def test_4_status_block_shows_the_line(self):
        st = status(self.s.modbus, 0, LINE + 14)
        self.assertEqual(st[LINE], 1)  # role slaves
        telegrams = (st[LINE + 1] << 16) | st[LINE + 2]
        requests = (st[LINE + 7] << 16) | st[LINE + 8]
        self.assertGreaterEqual(telegrams, 8)
        self.assertGreaterEqual(requests, 8)
        self.assertEqual(st[LINE + 13], 1)  # a master talks to it
        self.assertGreater(st[LINE + 12], 0)  # a response time was measured

    def test_5_cfg_fault_read_over_fdl(self):
        diag = self.master.parameterize(STATION, cfg=CFG_BAD)
        self.assertTrue(diag[0] & 0x04, "no Cfg_Fault in " + diag.hex())  # emulator-spec §3
        self.assertEqual(diag[8:11], bytes([0x3E, 1, 3]))  # slot 1, code 3 wrong length
        diag = self.master.parameterize(STATION)  # and back
        self.assertFalse(diag[0] & 0x06, diag.hex())

    def test_6_watchdog_expiry_when_the_master_stops(self):
        s = self.s
        self.master.data_exchange(STATION, bytes.fromhex("0A 0B 0C 0D 0E 0F"))
        self.assertEqual(status(s.modbus)[0], 2)
        s.drain_bus()
        t0 = time.monotonic()
        # The master stops; WD 300 ms (Set_Prm of the capture): S leaves Data_Exch.
        ok = eventually(lambda: status(s.modbus)[0] == 0, timeout=WAIT)
        self.assertTrue(ok, "S still in Data_Exch:\n" + s.daemon.log())
        self.assertGreaterEqual(time.monotonic() - t0, 0.25)
        self.assertTrue(eventually(lambda: "master lost" in s.daemon.log()), s.daemon.log())
        s.drain_bus()
        self.assertIsNone(s.bus.recv(timeout=0.5), "S's gateway still sends on CAN")


class TestStartErrors(unittest.TestCase):
    """Bad profibus sections and ports: exit status and a message naming the place."""

    def run_daemon(self, profibus):
        tmp = tempfile.mkdtemp(prefix="candp2-pb-err-")
        try:
            cfg = slaves_config(os.path.join(tmp, "pb"), free_port(), free_port())
            cfg["profibus"].update(profibus(tmp))
            path = os.path.join(tmp, "bad.json")
            with open(path, "w") as f:
                json.dump(cfg, f)
            r = subprocess.run([CANDP2D, "--config", path], capture_output=True, text=True,
                               timeout=WAIT)
            return r.returncode, r.stdout + r.stderr
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def test_baud_not_supported(self):
        rc, out = self.run_daemon(lambda tmp: {"baud": 115200})
        self.assertEqual(rc, 2, out)
        self.assertIn("$.profibus.baud", out)
        self.assertIn("93750", out)

    def test_unknown_device(self):
        rc, out = self.run_daemon(lambda tmp: {"port": os.path.join(tmp, "ttyUSB9")})
        self.assertEqual(rc, 2, out)
        self.assertIn("$.profibus.port", out)
        self.assertIn("does not exist", out)

    def test_pty_path_is_a_regular_file(self):
        def regular_file(tmp):
            path = os.path.join(tmp, "file")
            with open(path, "w") as f:
                f.write("keep")
            return {"port": "pty:" + path}
        rc, out = self.run_daemon(regular_file)
        self.assertEqual(rc, 1, out)
        self.assertIn("not a symbolic link", out)


class TestTwoDaemons(unittest.TestCase):
    """Process M (role master) drives process S (role slaves) over the pty."""

    @classmethod
    def setUpClass(cls):
        cls.s = SlaveSide()
        cls.tmp = tempfile.mkdtemp(prefix="candp2-pb-m-")
        cls.m_port = free_port()
        cls.m = None

    @classmethod
    def tearDownClass(cls):
        if cls.m:
            cls.m.kill()
        cls.s.close()
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def start_master(self, slots, name="M"):
        cfg = {"modbus": {"listen": "127.0.0.1:%d" % self.m_port},
               "master": {"address": MASTER, "cycle_ms": 5, "retry_ms": 100},
               "profibus": {"port": self.s.link, "baud": 19200, "role": "master"},
               "gateways": [{"address": STATION, "parameters": {"watchdog_ms": 300},
                             "slots": slots}],
               "log": {"level": "debug"}}
        d = Candp2d(self.tmp, name, cfg)
        d.wait_for_port(self.m_port)
        client = ModbusTcpClient("127.0.0.1", port=self.m_port, timeout=3)
        assert client.connect()
        return d, client

    def test_1_cfg_fault_diagnosis_on_m(self):
        bad = slots_514()
        bad[1]["length"] = 9  # emulator-spec §2 code 3
        m, client = self.start_master(bad, "Mbad")
        try:
            ok = eventually(lambda: (lambda st: st[1] & 0x04 and st[9:12] == [0x3E, 1, 3])(
                status(client, 0, 12)))
            self.assertTrue(ok, "M shows no Cfg fault:\n" + m.log())
        finally:
            client.close()
            m.kill()

    def test_2_round_trip_then_watchdog(self):
        s = self.s
        m, client = self.start_master(slots_514())
        type(self).m = m
        try:
            ok = eventually(lambda: status(client)[0] == 2 and status(s.modbus)[0] == 2)
            self.assertTrue(ok, "not in Data_Exch:\nM:\n" + m.log() + "\nS:\n" + s.daemon.log())
            s.drain_bus()
            # Modbus write on M (Q 172..177 = holding registers 86..88) -> frame on S's bus.
            client.write_registers(86, [0x1122, 0x3344, 0x5566], slave=STATION)
            s.expect_frame(0x309, bytes.fromhex("22 11 66 55 44 33"))
            # Frame injected on S's bus -> M's input registers 86..88.
            s.bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("A1 A2 A3 A4 A5 A6"),
                                   is_extended_id=False))
            want = bytes.fromhex("A2 A1 A6 A5 A4 A3")
            ok = eventually(lambda: regs_to_bytes(
                client.read_input_registers(86, 3, slave=STATION).registers) == want)
            self.assertTrue(ok, "inputs not on M:\n" + m.log())
            client.close()
            # kill -9 M: S's gateway leaves Data_Exch after the watchdog (300 ms).
            m.kill(signal.SIGKILL)
            ok = eventually(lambda: status(s.modbus)[0] == 0)
            self.assertTrue(ok, "S still in Data_Exch:\n" + s.daemon.log())
            s.drain_bus()
            self.assertIsNone(s.bus.recv(timeout=0.5), "S's gateway still sends on CAN")
        finally:
            m.kill()

    def wait_data_exch(self, m, client):
        s = self.s
        ok = eventually(lambda: status(client)[0] == 2 and status(s.modbus)[0] == 2)
        self.assertTrue(ok, "not in Data_Exch:\nM:\n" + m.log() + "\nS:\n" + s.daemon.log())

    def test_3_status_block_and_control_on_m(self):
        m, client = self.start_master(slots_514(), "Mctl")
        try:
            self.wait_data_exch(m, client)
            st = status(client, 0, LINE + 14)
            # docs/modbus.md: line group, role 2 = master; FdlMaster statistics of station 3.
            self.assertEqual(st[LINE], 2)
            self.assertGreater((st[LINE + 1] << 16) | st[LINE + 2], 0)   # telegrams on the line
            self.assertGreater((st[LINE + 7] << 16) | st[LINE + 8], 0)   # requests to station 3
            self.assertGreater(st[LINE + 12], 0)                          # highest response time
            self.assertEqual(st[LINE + 13], 1)                            # station present
            self.assertEqual(st[34], STATION)                             # DP address
            self.assertEqual(st[16:24], [0] * 8)  # CAN counters of a remote station read 0
            prm = (st[35] << 16) | st[36]
            self.assertGreaterEqual(prm, 1)
            # Control register 8192 = 1: a power cycle cannot reach a remote device (0x04).
            rr = client.write_register(8192, 1, slave=STATION)
            self.assertTrue(rr.isError(), rr)
            self.assertEqual(rr.exception_code, 0x04)
            m.wait_for_line("power cycle requested over Modbus refused")
            # 8192 = 2: the master parameterizes the remote station again (over FDL).
            rr = client.write_register(8192, 2, slave=STATION)
            self.assertFalse(rr.isError(), rr)
            ok = eventually(lambda: (lambda b: (b[35] << 16 | b[36]) > prm and b[0] == 2)(
                status(client, 0, 37)))
            self.assertTrue(ok, "not parameterized again:\n" + m.log())
        finally:
            client.close()
            m.kill()

    def test_4_station_lost_and_back(self):
        s = self.s
        m, client = self.start_master(slots_514(), "Mlost")
        try:
            self.wait_data_exch(m, client)
            prm = (lambda b: b[35] << 16 | b[36])(status(client, 0, 37))
            # S dies: M's diagnosis of station 3 shows Station_Non_Existent (diag byte 0 bit 0).
            s.stop(signal.SIGKILL)
            ok = eventually(lambda: (lambda b: b[1] & 0x01 and b[0] == 0 and b[LINE + 13] == 0)(
                status(client, 0, LINE + 14)))
            self.assertTrue(ok, "M shows no Station_Non_Existent:\n" + m.log())
            m.wait_for_line("station 3: lost")
            # M's end of the pty is dead (S held the pty): M closes it and tries again.
            m.wait_for_line("the PROFIBUS line is down")
            # S back on the same pty path: M parameterizes it again and exchanges data.
            s.start()
            self.wait_data_exch(m, client)
            b = status(client, 0, LINE + 14)
            self.assertEqual(b[1] & 0x01, 0)
            self.assertGreater(b[35] << 16 | b[36], prm)
            self.assertEqual(b[LINE + 13], 1)
            m.wait_for_line("station 3: answers again")
            self.assertIn("port open again", m.log())
            # And the data flow again: Modbus write on M -> frame on S's bus.
            s.drain_bus()
            client.write_registers(86, [0x0102, 0x0304, 0x0506], slave=STATION)
            s.expect_frame(0x309, bytes.fromhex("02 01 06 05 04 03"))
        finally:
            client.close()
            m.kill()


def main():
    global CANDP2D
    parser = argparse.ArgumentParser()
    parser.add_argument("--candp2d", required=True)
    args, rest = parser.parse_known_args()
    CANDP2D = os.path.abspath(args.candp2d)
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
