"""An independent DP master drives generic slaves served by candp2d over a pseudo-terminal
(docs/slaves.md "An independent master over a pty"; pytest on the candp2 package, ctest
e2e_gsd_slave_pty).

candp2d runs `profibus.role: "slaves"` on `pty:<tmp>/pb` with, on that one line, a CAN-DP/2
gateway at 3 (the manual §5.1.4 slots, on a virtual CAN bus) and two generic slaves from the
project's own GSD files (tests/gsd/data/README.md): a DP/DP coupler (CP2COUPL.GSD, modular,
Sync/Freeze) at 9 and a motor starter (CP2MOTOR.GSD, bit areas, no Sync/Freeze) at 8, each with its
field side on a Modbus unit of its own.

The master is this file and independent of our C++: it reads the same GSD files with its own small
reader (Ident_Number, modules, User_Prm_Data, Ext_User_Prm_Data_Const/Ref, ExtUserPrmData
defaults), builds Set_Prm and Chk_Cfg from its own module list, and talks FDL through the minimal
master of profibus_e2e.py. The test plays the field through the candp2 package (Modbus: the
slaves' field sides and fault registers). Shown: Data_Exchange with the coupler (its outputs
appear on the field side, inputs written there come back), a Cfg fault (another module list), a
Prm fault (a value out of range), Sync refused by the motor starter and honoured by the coupler
(Global_Control), the slave leaving the bus and coming back, a diagnosis alarm announced with DH,
and the gateway exchanging data on the same line beside the slaves.

Every wait is bounded; every daemon is stopped (the candp2d fixture).
"""

import os
import re
import time

import can  # python3-can
import pytest

from profibus_e2e import CFG_514, PRM_300MS, SC, SD2, SD3, FdlMaster, sd2, slots_514

HERE = os.path.dirname(os.path.abspath(__file__))
GSD_DATA = os.path.normpath(os.path.join(HERE, "..", "gsd", "data"))
WAIT = 10.0
SAP_DIAG, SAP_GC, SAP_MASTER = 60, 58, 62
FC_DL, FC_DH = 0x08, 0x0A
GATEWAY, COUPLER, STARTER = 3, 9, 8
COUPLER_MODULES = ["4 Bytes Output consistent", "2 Bytes Input", "1 Byte Output"]


# ------------------------------------------------------------------ a small GSD reader of our own

class Gsd:
    """What a master needs from a GSD (PNO GSD specification keywords), read independently."""

    def __init__(self, path):
        with open(path, "rb") as f:
            text = f.read().decode("latin-1")
        lines, cur = [], ""
        for raw in text.splitlines():
            line = re.sub(r";.*$", "", raw) if '"' not in raw else raw  # comments outside strings
            line = line.rstrip()
            if line.endswith("\\"):
                cur += line[:-1]
                continue
            lines.append((cur + line).strip())
            cur = ""
        self.ident = None
        self.modules = {}          # name (trimmed) -> config bytes
        self.presets = []          # the modules with Preset = 1, in GSD order
        self.prm_data = {}         # ExtUserPrmData ref -> (type, bits, default)
        self.consts, self.refs = [], []
        self.user_prm_len, self.user_prm_data = 0, b""
        block = None
        for line in lines:
            if not line:
                continue
            key, _, value = line.partition("=")
            key, value = key.strip(), value.strip()
            k = key.lower()
            if block and block[0] == "module":
                if k == "endmodule":
                    block = None
                elif k == "preset" and int(value, 0) == 1:
                    self.presets.append(block[1])
                continue
            if block and block[0] == "ext":
                if k == "endextuserprmdata":
                    block = None
                elif not value and block[1] not in self.prm_data:
                    self.prm_data[block[1]] = self.parse_type(line)
                continue
            if k == "module":
                m = re.match(r'"([^"]*)"\s*(.*)', value)
                cfg = m.group(2).replace(" ", "").split(",")
                self.modules[m.group(1).strip()] = bytes(int(x, 0) for x in cfg if x)
                block = ("module", m.group(1).strip())
            elif k == "extuserprmdata":
                block = ("ext", int(value.split()[0], 0))
            elif k == "ident_number":
                self.ident = int(value, 0)
            elif k == "user_prm_data_len":
                self.user_prm_len = int(value, 0)
            elif k == "user_prm_data":
                self.user_prm_data = bytes(int(x, 0) for x in value.split(","))
            elif k.startswith("ext_user_prm_data_const("):
                self.consts.append((int(key[key.index("(") + 1:-1], 0),
                                    bytes(int(x, 0) for x in value.split(","))))
            elif k.startswith("ext_user_prm_data_ref("):
                self.refs.append((int(key[key.index("(") + 1:-1], 0), int(value, 0)))

    @staticmethod
    def parse_type(line):
        m = re.match(r"(Bit|BitArea)\((\d+)(?:-(\d+))?\)\s+(-?\w+)", line)
        if m:
            first = int(m.group(2))
            last = int(m.group(3)) if m.group(3) else first
            return ("bits", (first, last), int(m.group(4), 0))
        m = re.match(r"(Unsigned|Signed)(8|16|32)\s+(-?\w+)", line)
        return ("int", int(m.group(2)) // 8, int(m.group(3), 0))

    def user_prm(self, values=None):
        """The default user parameter bytes, with {offset: value} of referenced parameters."""
        values = values or {}
        size = max([self.user_prm_len, len(self.user_prm_data)] +
                   [o + len(b) for o, b in self.consts] +
                   [o + (self.prm_data[r][1] if self.prm_data[r][0] == "int" else 1)
                    for o, r in self.refs])
        out = bytearray(size)
        out[:len(self.user_prm_data)] = self.user_prm_data
        for o, b in self.consts:
            out[o:o + len(b)] = b
        for o, r in self.refs:
            kind, shape, default = self.prm_data[r]
            v = values.get(o, default)
            if kind == "bits":
                first, last = shape
                mask = ((1 << (last - first + 1)) - 1) << first
                out[o] = (out[o] & ~mask) | ((v << first) & mask)
            else:
                out[o:o + shape] = v.to_bytes(shape, "big")
        return bytes(out)

    def set_prm(self, watchdog_ms=300, sync=False, values=None):
        status = 0x80 | (0x08 if watchdog_ms else 0) | (0x20 if sync else 0)  # Lock_Req, WD_On
        f1 = max(1, min(255, (watchdog_ms + 9) // 10))
        return bytes([status, f1, 1, 0, self.ident >> 8, self.ident & 0xFF, 0]) + \
            self.user_prm(values)

    def chk_cfg(self, names):
        return b"".join(self.modules[n] for n in names)

    def tool_chk_cfg(self, names):
        """Chk_Cfg as configuration tools build it (pyprofibus, STEP 7; docs/slaves.md "Preset
        modules"): the preset modules first, in GSD order, then the user's modules."""
        return self.chk_cfg(self.presets + list(names))


# ------------------------------------------------------------------ the line

def response_fc(r):
    if r[0] == SD2:
        return r[6] & 0x0F
    if r[0] == SD3:
        return r[3] & 0x0F
    return r[3] & 0x0F  # SD1


def line_config(link):
    return {
        "profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
        "buses": {"can0": {"type": "virtual"}},
        "gateways": [{"name": "gw3", "address": GATEWAY, "bus": "can0", "slots": slots_514()}],
        "slaves": [
            {"name": "coupler", "address": COUPLER, "gsd": os.path.join(GSD_DATA, "CP2COUPL.GSD"),
             "modules": COUPLER_MODULES, "field_unit": 100 + COUPLER},
            {"name": "starter", "address": STARTER,
             "gsd": os.path.join(GSD_DATA, "CP2MOTOR.GSD"), "modules": ["Starter Standard"],
             "field_unit": 100 + STARTER},
        ],
        "log": {"level": "debug"},
    }


class Line:
    """candp2d on the slave side of the pty, the test's FDL master on the other."""

    def __init__(self, daemon, link):
        self.daemon = daemon
        self.master = FdlMaster(link)
        self.coupler = daemon.slave("coupler")
        self.starter = daemon.slave("starter")

    def diag(self, station):
        """Slave_Diag: SD2, or SD3 when the SAPs and data are exactly 8 bytes (a 6-byte
        diagnosis; IEC 61158-4-3 SD3 carries a fixed 8-byte information field)."""
        r = self.master.srd(station, b"", dsap=SAP_DIAG)
        assert r, "no answer to Slave_Diag"
        if r[0] == SD3:
            assert (r[1] & 0x80, r[2] & 0x80, r[4], r[5]) == (0x80, 0x80, 62, SAP_DIAG)
            return r[6:12]
        assert r[0] == SD2, r.hex(" ")
        return r[9:-2]  # after 68 LE LEr 68 DA SA FC DSAP SSAP

    def parameterize(self, station, prm, cfg):
        assert self.master.fdl_status(station) is not None, "no FDL_Status answer"
        self.diag(station)
        assert self.master.set_prm(station, prm) == bytes([SC])
        assert self.master.chk_cfg(station, cfg) == bytes([SC])
        return self.diag(station)

    def exchange(self, station, outputs):
        r, inputs = self.master.data_exchange(station, outputs)
        return response_fc(r), inputs

    def exchange_until(self, station, outputs, predicate):
        """Data_Exchange until `predicate(fc, inputs)` holds (bounded); the last (fc, inputs)."""
        end = time.monotonic() + WAIT
        fc, inputs = self.exchange(station, outputs)
        while not predicate(fc, inputs) and time.monotonic() < end:
            fc, inputs = self.exchange(station, outputs)
        return fc, inputs

    def global_control(self, station, control):
        # SDN high (FC 0x46), DSAP 58: no answer (IEC 61158-6-3 Global_Control).
        # The next request on the line is handled after it: the slave reads the line in order.
        os.write(self.master.fd, sd2(station, self.master.address, 0x46, bytes([control, 0]),
                                     SAP_GC, SAP_MASTER))


@pytest.fixture(scope="module")
def gsd():
    return {"coupler": Gsd(os.path.join(GSD_DATA, "CP2COUPL.GSD")),
            "starter": Gsd(os.path.join(GSD_DATA, "CP2MOTOR.GSD"))}


def serve_line(candp2d, tmp_path, config_of, make_line):
    """candp2d serving config_of(link) in role slaves on a pty link, and make_line(daemon, link)
    (the test's master on it); the caller closes line.master."""
    link = str(tmp_path / "pb")
    daemon = candp2d(config_of(link))
    assert os.path.islink(link), "no pty link at " + link
    return make_line(daemon, link)


@pytest.fixture
def line(candp2d, tmp_path):
    line = serve_line(candp2d, tmp_path, line_config, Line)
    yield line
    line.master.close()


# ------------------------------------------------------------------ the tests

def test_data_exchange_with_its_own_module_list(line, gsd):
    c = gsd["coupler"]
    diag = line.parameterize(COUPLER, c.set_prm(), c.chk_cfg(COUPLER_MODULES))
    assert diag.hex(" ") == "00 0c 00 02 0c 70"  # WD_On, master 2, ident 0C70
    fc, inputs = line.exchange(COUPLER, bytes([0x11, 0x22, 0x33, 0x44, 0x55]))
    assert inputs == bytes(2)
    line.coupler.wait_until(lambda s: s.field_outputs[0:5] == bytes.fromhex("11 22 33 44 55"),
                            timeout=WAIT)
    line.coupler.field_inputs[0:2] = b"\xA5\x5A"
    fc, inputs = line.exchange_until(COUPLER, bytes([0x11, 0x22, 0x33, 0x44, 0x55]),
                                     lambda fc, i: i == b"\xA5\x5A")
    assert inputs == b"\xA5\x5A"
    assert fc == FC_DL
    # candp2d's view of the line: role slaves, requests to the coupler, a master talks to it.
    st = line.coupler.status
    assert (st["line_role"], st["station_present"]) == (1, 1)
    assert st["station_requests"] >= 6
    assert line.coupler.state == "Data_Exch" and line.coupler.diagnosis.master == 2


def test_other_module_list_is_cfg_fault(line, gsd):
    c = gsd["coupler"]
    diag = line.parameterize(COUPLER, c.set_prm(),
                             c.chk_cfg(["4 Bytes Output consistent", "2 Bytes Input"]))
    assert diag[0] == 0x06  # Station_Not_Ready + Cfg_Fault
    assert "Chk_Cfg entry 2" in line.daemon.log  # the slave's log names the difference


def test_value_out_of_range_is_prm_fault(line, gsd):
    s = gsd["starter"]
    # "Class" (ExtUserPrmData 6, Unsigned8 5-30) at user byte 9.
    diag = line.parameterize(STARTER, s.set_prm(values={9: 40}), s.chk_cfg(["Starter Standard"]))
    assert diag[0] == 0x42  # Station_Not_Ready + Prm_Fault
    diag = line.parameterize(STARTER, s.set_prm(values={9: 20}), s.chk_cfg(["Starter Standard"]))
    assert diag.hex(" ") == "00 0c 00 02 0c 31"


def test_sync_refused_by_one_honoured_by_the_other(line, gsd):
    s, c = gsd["starter"], gsd["coupler"]
    diag = line.parameterize(STARTER, s.set_prm(sync=True), s.chk_cfg(["Starter Standard"]))
    assert diag[0] == 0x12  # Station_Not_Ready + Not_Supported
    diag = line.parameterize(COUPLER, c.set_prm(sync=True), c.chk_cfg(COUPLER_MODULES))
    assert diag[0] == 0x00
    line.exchange(COUPLER, bytes([1, 1, 1, 1, 1]))
    line.coupler.wait_until(lambda s: s.field_outputs[0:5] == bytes([1] * 5), timeout=WAIT)
    line.global_control(COUPLER, 0x20)  # Sync
    assert line.diag(COUPLER)[1] & 0x20  # Sync_Mode
    line.exchange(COUPLER, bytes([2, 2, 2, 2, 2]))
    line.exchange(COUPLER, bytes([2, 2, 2, 2, 2]))
    # candp2d answered both, so it has handled them: the field still shows the synced outputs,
    # held until the next Sync.
    assert line.coupler.field_outputs[0:5] == bytes([1] * 5)
    assert "Sync_Mode" in line.coupler.diagnosis
    line.global_control(COUPLER, 0x20)
    line.coupler.wait_until(lambda s: s.field_outputs[0:5] == bytes([2] * 5), timeout=WAIT)


def test_leaves_the_bus_and_comes_back(line, gsd):
    c = gsd["coupler"]
    line.parameterize(COUPLER, c.set_prm(watchdog_ms=200), c.chk_cfg(COUPLER_MODULES))
    line.coupler.leave_bus()
    assert line.master.srd(COUPLER, b"", dsap=SAP_DIAG) is None
    # Its watchdog (200 ms) expired meanwhile.
    line.coupler.wait_until(lambda s: s.state == "Wait_Prm", timeout=WAIT)
    line.coupler.return_to_bus()
    diag = line.parameterize(COUPLER, c.set_prm(), c.chk_cfg(COUPLER_MODULES))
    assert diag[0] == 0x00


def test_diagnosis_alarm_is_announced_with_dh(line, gsd):
    c = gsd["coupler"]
    line.parameterize(COUPLER, c.set_prm(), c.chk_cfg(COUPLER_MODULES))
    fc, _ = line.exchange(COUPLER, bytes(5))
    assert fc == FC_DL
    line.coupler.alarm(b"\x42\x43")
    fc, _ = line.exchange_until(COUPLER, bytes(5), lambda fc, i: fc == FC_DH)
    assert fc == FC_DH
    diag = line.diag(COUPLER)
    assert diag.hex(" ") == "08 0c 00 02 0c 70 03 42 43"  # Ext_Diag, device block
    assert line.coupler.diagnosis.raw == bytes(diag)  # what candp2d's Modbus face shows


def test_the_gateway_on_the_same_line(line, gsd):
    """The CAN-DP/2 among the generic slaves: one master, one line, both exchange data, and the
    gateway goes on when a slave leaves the bus."""
    c = gsd["coupler"]
    can0 = line.daemon.bus("can0")
    diag = line.parameterize(GATEWAY, PRM_300MS, CFG_514)
    assert not diag[0] & 0x06, diag.hex(" ")
    line.parameterize(COUPLER, c.set_prm(), c.chk_cfg(COUPLER_MODULES))
    line.exchange(GATEWAY, bytes.fromhex("01 02 03 04 05 06"))
    can0.expect(0x309, bytes.fromhex("02 01 06 05 04 03"), timeout=WAIT)  # form B8 swaps
    line.exchange(COUPLER, bytes.fromhex("AA BB CC DD EE"))
    line.coupler.wait_until(lambda s: s.field_outputs[0:5] == bytes.fromhex("AA BB CC DD EE"),
                            timeout=WAIT)
    gw = line.daemon.gateway("gw3")
    assert gw.state == "Data_Exch" and line.coupler.state == "Data_Exch"
    # The coupler leaves the bus; the gateway goes on: CAN -> its inputs over FDL.
    line.coupler.leave_bus()
    for _ in range(3):  # the master goes on polling it: no answer within its slot time
        request = sd2(COUPLER, line.master.address, 0x7D, bytes.fromhex("AA BB CC DD EE"))
        assert line.master.transact(request, timeout=0.05) is None
    can0.send(can.Message(arbitration_id=0x289, data=bytes.fromhex("A1 A2 A3 A4 A5 A6"),
                          is_extended_id=False))
    _, inputs = line.exchange_until(GATEWAY, bytes.fromhex("01 02 03 04 05 06"),
                                    lambda fc, i: i == bytes.fromhex("A2 A1 A6 A5 A4 A3"))
    assert inputs == bytes.fromhex("A2 A1 A6 A5 A4 A3")
    assert gw.state == "Data_Exch"
    assert re.search(r"coupler: leaves the bus", line.daemon.log)
