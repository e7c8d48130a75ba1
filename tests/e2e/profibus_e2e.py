"""End-to-end test of candp2d's PROFIBUS line (docs/profibus.md) over a pseudo-terminal (pytest
on the candp2 package; ctest e2e_profibus).

Process S runs `profibus.role: "slaves"` on `pty:<tmp>/pb` with gateway 3 (the manual §5.1.4 slots)
on a virtual CAN bus exported over socketcand. It is driven over the pty by:

  * a small FDL master written here (test code: telegrams built from the tables in docs/profibus.md,
    the first telegrams byte for byte as in its capture), and
  * a second candp2d, process M, with `role: "master"` on the same pty (the link path opened as a
    serial device) driving remote gateway 3.

Shown: (a) the manual §5.1.4 round trip (outputs over FDL -> frame on S's bus; a frame injected on
S's bus -> the inputs in the Data_Exchange answer, in S's and in M's Modbus image); (b) a Cfg
fault diagnosis read over FDL (Cfg_Fault, 3E slot code); (c) watchdog expiry when the master
stops (S's status block: DP state Wait_Prm; no more CAN Tx); (d) S killed -> M's status block
shows Station_Non_Existent; S restarted on the same pty path -> M parameterizes it again. Plus: S
refuses Modbus writes to its output image with exception 0x04, M refuses a power cycle of a remote
station with exception 0x04 and re-parameterizes it on request, and both status blocks show the
line counters (by field name, from the daemon's own map).

Every wait is bounded by a deadline; the daemons are always stopped. The tests of each class run
in file order.
"""

import os
import select
import shutil
import tempfile
import time
import tty

import can  # python3-can
import pytest

import candp2

WAIT = 10.0  # seconds: upper bound for anything that should happen within a few cycles
STATION = 3  # the gateway's DP address
# the test master's address (the capture in docs/profibus.md "A real master's first telegrams":
# class 1 master at 2)
MASTER = 2

# docs/profibus.md: SD1 0x10, SD2 0x68, SD3 0xA2, SC 0xE5, ED 0x16; SAPs of the DP services.
SD1, SD2, SD3, SC, ED = 0x10, 0x68, 0xA2, 0xE5, 0x16
SAP_DIAG, SAP_PRM, SAP_CFG, SAP_MASTER = 60, 61, 62, 62

# manual §5.1.4 slots (special identifier format, docs/slots.md "Chk_Cfg slots"): input 6 bytes from
# 0x289, output 6 bytes to 0x309, form B8.
CFG_514 = bytes.fromhex("43 85 02 89 B8 83 85 03 09 B8")
# Output slot with 9 data bytes: wrong length (docs/slots.md "Chk_Cfg slots" code 3) in slot 1.
CFG_BAD = bytes.fromhex("43 85 02 89 B8 83 88 03 09 B8")
# the capture in docs/profibus.md "A real master's first telegrams": WD on, 300 ms (30 x 1 x 10 ms),
# ident 04A4, GSD default user bytes.
PRM_300MS = bytes.fromhex("88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF")


def eventually(check, timeout=WAIT):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.01)
    return check()


def wait_for_line(daemon, needle, timeout=WAIT):
    """Waits until the daemon's log has `needle` (bounded)."""
    eventually(lambda: needle in daemon.log or daemon.poll() is not None, timeout)
    if needle not in daemon.log:
        raise AssertionError("no '%s' in the log of %s:\n%s"
                             % (needle, daemon.config_path, daemon.log))


def fcs(data):
    return sum(data) & 0xFF  # docs/profibus.md: arithmetic sum mod 256


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
    """A minimal class 1 master on the pty link: FCB/FCV as docs/profibus.md describes."""

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

    # DP services (the table in docs/profibus.md)
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


def slots_514():
    return [
        {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"},
    ]


def slaves_config(link):
    return {
        "profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
        "buses": {"can0": {"type": "virtual"}},
        "gateways": [{"name": "gw3", "address": STATION, "bus": "can0", "slots": slots_514()}],
        "log": {"level": "debug"},
    }


def dp_state(gw):
    return gw.state


class SlaveSide:
    """Process S and its observers: the package's gateway (Modbus) and bus (socketcand)."""

    def __init__(self, binary):
        self.binary = binary
        self.tmp = tempfile.mkdtemp(prefix="candp2-pb-e2e-")
        self.link = os.path.join(self.tmp, "pb")
        self.daemon = None
        self.start()

    def start(self):
        self.daemon = candp2.Daemon(slaves_config(self.link), self.binary)
        assert os.path.islink(self.link), "no pty link at " + self.link
        self.gw = self.daemon.gateway(STATION)
        self.bus = self.daemon.bus("can0")

    def stop(self):
        if self.daemon.returncode is None:
            self.daemon.stop(timeout=WAIT, check=False)

    def kill(self):
        self.daemon.kill()
        self.daemon.stop(check=False)

    def close(self):
        self.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def expect_frame(self, arbitration_id, data, timeout=WAIT):
        self.bus.expect(arbitration_id, data, timeout)


class TestMasterDrivesSlaves:
    """The test's FDL master against process S."""

    @pytest.fixture(scope="class")
    def s(self, candp2_binary):
        side = SlaveSide(candp2_binary)
        yield side
        side.close()

    @pytest.fixture(scope="class")
    def master(self, s):
        m = FdlMaster(s.link)
        yield m
        m.close()

    def test_1_capture_bytes_of_emulator_spec_10(self, s, master):
        m = master
        # The capture's first telegrams byte for byte; FDL_Status answer SD1 FC 0x00 (slave, OK).
        assert m.transact(bytes.fromhex("10 03 02 49 4E 16")) == \
            bytes([SD1, 0x02, 0x03, 0x00, 0x05, ED])
        diag = m.transact(bytes.fromhex("68 05 05 68 83 82 6D 3C 3E EC 16"))
        assert diag is not None, "no Slave_Diag answer:\n" + s.daemon.log
        # SD2, SAPs swapped (DSAP 62, SSAP 60), FC DL; 11 diagnosis bytes
        # (docs/dp-slave.md "Diagnosis").
        assert diag[:9] == bytes([SD2, 16, 16, SD2, 0x82, 0x83, 0x08, 0x3E, 0x3C])
        assert diag[12] == 0xFF   # byte 3: no master yet
        assert diag[13:15] == bytes([0x04, 0xA4])
        assert m.transact(bytes.fromhex(
            "68 15 15 68 83 82 5D 3D 3E 88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF 2C 16")) \
            == bytes([SC])
        assert m.transact(bytes.fromhex(
            "68 0F 0F 68 83 82 7D 3E 3E 43 85 02 89 B8 83 85 03 09 B8 D5 16")) == bytes([SC])
        diag = m.transact(bytes.fromhex("68 05 05 68 83 82 5D 3C 3E DC 16"))
        assert diag[9 + 3] == MASTER, diag.hex()  # parameterized by master 2
        assert not diag[9] & 0x02, "Station_Not_Ready after parameterization"
        r = m.transact(bytes.fromhex("68 09 09 68 03 02 7D 11 22 33 44 55 66 E7 16"))
        assert r is not None
        assert r[0] in (SD2, SD3, SC)
        # The output bytes go out on CAN, byte-swapped as form B8 says
        # (docs/slots.md "Data exchange in normal mode").
        s.expect_frame(0x309, bytes.fromhex("22 11 66 55 44 33"))
        s.gw.wait_until(lambda g: g.state == "Data_Exch", timeout=WAIT)
        m.fcb[STATION] = True  # the capture's last Data_Exchange had FCB=1

    def test_2_round_trip_and_wire_image(self, s, master):
        m = master
        s.bus.drain()
        m.data_exchange(STATION, bytes.fromhex("01 02 03 04 05 06"))
        s.expect_frame(0x309, bytes.fromhex("02 01 06 05 04 03"))
        # A frame injected on S's bus comes back in the Data_Exchange answer.
        s.bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("A1 A2 A3 A4 A5 A6"),
                               is_extended_id=False))
        want = bytes.fromhex("A2 A1 A6 A5 A4 A3")
        got = eventually(lambda: (lambda r: r[1] == want and r[1])(
            m.data_exchange(STATION, bytes.fromhex("01 02 03 04 05 06"))))
        assert got == want
        # S's Modbus image shows the wire: Q 172..177 as received, I 172..177 as sent.
        assert s.gw.outputs[172:178] == bytes.fromhex("01 02 03 04 05 06")
        assert s.gw.inputs[172:178] == want

    def test_3_output_image_is_read_only(self, s):
        with pytest.raises(candp2.ModbusError) as info:
            s.gw.outputs[172:174] = b"\x12\x34"
        assert info.value.code == 0x04
        wait_for_line(s.daemon, "exception 0x04")

    def test_4_status_block_shows_the_line(self, s):
        st = s.gw.status
        assert st["line_role"] == 1  # role slaves
        assert st["line_telegrams"] >= 8
        assert st["station_requests"] >= 8
        assert st["station_present"] == 1  # a master talks to it
        assert st["response_max_us"] > 0  # a response time was measured

    def test_5_cfg_fault_read_over_fdl(self, master):
        diag = master.parameterize(STATION, cfg=CFG_BAD)
        assert diag[0] & 0x04, "no Cfg_Fault in " + diag.hex()  # docs/dp-slave.md "Diagnosis"
        assert diag[8:11] == bytes([0x3E, 1, 3])  # slot 1, code 3 wrong length
        diag = master.parameterize(STATION)  # and back
        assert not diag[0] & 0x06, diag.hex()

    def test_6_watchdog_expiry_when_the_master_stops(self, s, master):
        master.data_exchange(STATION, bytes.fromhex("0A 0B 0C 0D 0E 0F"))
        assert s.gw.state == "Data_Exch"
        s.bus.drain()
        t0 = time.monotonic()
        # The master stops; WD 300 ms (Set_Prm of the capture): S leaves Data_Exch.
        s.gw.wait_until(lambda g: g.state == "Wait_Prm", timeout=WAIT)
        assert time.monotonic() - t0 >= 0.25
        wait_for_line(s.daemon, "master lost")
        s.bus.drain()
        s.bus.expect_no_frame(duration=0.5)  # S's gateway sends nothing on CAN


class TestStartErrors:
    """Bad profibus sections and ports: the error names the place; exit status 2 for the
    configuration, 1 for a start that fails."""

    def start(self, binary, tmp_path, profibus):
        cfg = slaves_config(str(tmp_path / "pb"))
        cfg["profibus"].update(profibus)
        candp2.Daemon(cfg, binary).stop()

    def test_baud_not_supported(self, candp2_binary, tmp_path):
        with pytest.raises(candp2.ConfigError) as info:
            self.start(candp2_binary, tmp_path, {"baud": 115200})
        assert info.value.returncode == 2
        assert info.value.path == "$.profibus.baud"
        assert "93750" in info.value.message

    def test_unknown_device(self, candp2_binary, tmp_path):
        with pytest.raises(candp2.ConfigError) as info:
            self.start(candp2_binary, tmp_path, {"port": str(tmp_path / "ttyUSB9")})
        assert info.value.returncode == 2
        assert info.value.path == "$.profibus.port"
        assert "does not exist" in info.value.message

    def test_pty_path_is_a_regular_file(self, candp2_binary, tmp_path):
        path = tmp_path / "file"
        path.write_text("keep")
        with pytest.raises(candp2.DaemonError) as info:
            self.start(candp2_binary, tmp_path, {"port": "pty:" + str(path)})
        assert info.value.returncode == 1
        assert "not a symbolic link" in str(info.value)
        assert path.read_text() == "keep"


class TestTwoDaemons:
    """Process M (role master) drives process S (role slaves) over the pty."""

    @pytest.fixture(scope="class")
    def s(self, candp2_binary):
        side = SlaveSide(candp2_binary)
        yield side
        side.close()

    @pytest.fixture
    def start_master(self, s, candp2_binary):
        started = []

        def start(slots):
            cfg = {"master": {"address": MASTER, "cycle_ms": 5, "retry_ms": 100},
                   "profibus": {"port": s.link, "baud": 19200, "role": "master"},
                   "gateways": [{"address": STATION, "parameters": {"watchdog_ms": 300},
                                 "slots": slots}],
                   "log": {"level": "debug"}}
            m = candp2.Daemon(cfg, candp2_binary)
            started.append(m)
            return m, m.gateway(STATION)

        yield start
        for m in started:
            m.stop(check=False)

    @staticmethod
    def wait_data_exch(m, gw, s):
        ok = eventually(lambda: gw.state == "Data_Exch" and s.gw.state == "Data_Exch")
        assert ok, "not in Data_Exch:\nM:\n" + m.log + "\nS:\n" + s.daemon.log

    def test_1_cfg_fault_diagnosis_on_m(self, s, start_master):
        bad = slots_514()
        bad[1]["length"] = 9  # docs/slots.md "Chk_Cfg slots" code 3
        m, gw = start_master(bad)
        gw.wait_until(lambda g: "Cfg_Fault" in g.diagnosis
                      and g.diagnosis.cfg_fault == candp2.CfgFault(slot=1, code=3),
                      timeout=WAIT)
        assert gw.diagnosis[8:11] == bytes([0x3E, 1, 3])

    def test_2_round_trip_then_watchdog(self, s, start_master):
        m, gw = start_master(slots_514())
        self.wait_data_exch(m, gw, s)
        s.bus.drain()
        # Modbus write on M (Q 172..177) -> frame on S's bus.
        gw.outputs[172:178] = bytes.fromhex("11 22 33 44 55 66")
        s.expect_frame(0x309, bytes.fromhex("22 11 66 55 44 33"))
        # Frame injected on S's bus -> M's input image I 172..177.
        s.bus.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("A1 A2 A3 A4 A5 A6"),
                               is_extended_id=False))
        want = bytes.fromhex("A2 A1 A6 A5 A4 A3")
        gw.wait_until(lambda g: g.inputs[172:178] == want, timeout=WAIT)
        # kill -9 M: S's gateway leaves Data_Exch after the watchdog (300 ms).
        m.kill()
        s.gw.wait_until(lambda g: g.state == "Wait_Prm", timeout=WAIT)
        s.bus.drain()
        s.bus.expect_no_frame(duration=0.5)  # S's gateway sends nothing on CAN

    def test_3_status_block_and_control_on_m(self, s, start_master):
        m, gw = start_master(slots_514())
        self.wait_data_exch(m, gw, s)
        st = gw.status
        # docs/modbus.md: line group, role 2 = master; FdlMaster statistics of station 3.
        assert st["line_role"] == 2
        assert st["line_telegrams"] > 0    # telegrams on the line
        assert st["station_requests"] > 0  # requests to station 3
        assert st["response_max_us"] > 0   # highest response time
        assert st["station_present"] == 1  # station present
        assert st["dp_address"] == STATION
        # CAN counters of a remote station read 0.
        assert [st[k] for k in ("rx_frames", "tx_frames", "irq_lost", "msg_lost")] == [0] * 4
        prm = st["parameterizations"]
        assert prm >= 1
        # Control power_cycle: a power cycle cannot reach a remote device (0x04).
        with pytest.raises(candp2.ModbusError) as info:
            gw.power_cycle()
        assert info.value.code == 0x04
        wait_for_line(m, "power cycle requested over Modbus refused")
        # reparameterize: the master parameterizes the remote station again (over FDL).
        gw.reparameterize()
        gw.wait_until(lambda g: g.counters.parameterizations > prm and g.state == "Data_Exch",
                      timeout=WAIT)

    def test_4_station_lost_and_back(self, s, start_master):
        m, gw = start_master(slots_514())
        self.wait_data_exch(m, gw, s)
        prm = gw.counters.parameterizations
        # S dies: M's diagnosis of station 3 shows Station_Non_Existent (diag byte 0 bit 0).
        s.kill()
        gw.wait_until(lambda g: "Station_Non_Existent" in g.diagnosis and g.state == "Wait_Prm"
                      and g.status["station_present"] == 0, timeout=WAIT)
        wait_for_line(m, "station 3: lost")
        # M's end of the pty is dead (S held the pty): M closes it and tries again.
        wait_for_line(m, "the PROFIBUS line is down")
        # S back on the same pty path: M parameterizes it again and exchanges data.
        s.start()
        self.wait_data_exch(m, gw, s)
        st = gw.status
        assert "Station_Non_Existent" not in gw.diagnosis
        assert st["parameterizations"] > prm
        assert st["station_present"] == 1
        wait_for_line(m, "station 3: answers again")
        assert "port open again" in m.log
        # And the data flow again: Modbus write on M -> frame on S's bus.
        s.bus.drain()
        gw.outputs[172:178] = bytes.fromhex("01 02 03 04 05 06")
        s.expect_frame(0x309, bytes.fromhex("02 01 06 05 04 03"))
