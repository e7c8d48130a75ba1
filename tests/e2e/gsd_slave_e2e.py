#!/usr/bin/python3
"""An independent DP master drives generic slaves over a pseudo-terminal (docs/slaves.md).

The slaves: tests/gsd_slave/pty_slaves.cpp (gsd_slave_pty) serves the `slaves` of a daemon
configuration on `pty:<tmp>/pb` with the FDL slave front end — a SIEMENS DP/DP Coupler
(SIEM8070.GSD, modular, Sync/Freeze) at 9 and a SIEMENS SIMOCODE-DP (SIEM8031.GSE, bit areas, no
Sync/Freeze) at 8, from ../shared/gsd-corpus.

The master is this file and independent of our C++: it reads the same GSD files with its own small
reader (Ident_Number, modules, User_Prm_Data, Ext_User_Prm_Data_Const/Ref, ExtUserPrmData
defaults), builds Set_Prm and Chk_Cfg from its own module list, and talks FDL through the minimal
master of profibus_e2e.py. Shown: Data_Exchange with the coupler (its outputs appear on the field
side, inputs written there come back), a Cfg fault (another module list), a Prm fault (a value
out of range), Sync refused by the SIMOCODE-DP and honoured by the coupler (Global_Control), the
slave leaving the bus and coming back, a diagnosis alarm announced with DH.

Run by ctest (label e2e) with Debian's /usr/bin/python3 (profibus_e2e.py imports python3-can and
python3-pymodbus):
    /usr/bin/python3 tests/e2e/gsd_slave_e2e.py --harness build/tests/gsd_slave_pty
Every wait is bounded; the harness is always stopped.
"""

import argparse
import json
import os
import re
import select
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

from profibus_e2e import FdlMaster, sd2, SC, SD2, SD3  # tests/e2e (the script's folder)

HARNESS = None
CORPUS = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared",
                                       "gsd-corpus"))
WAIT = 10.0
SAP_DIAG, SAP_PRM, SAP_CFG, SAP_GC, SAP_MASTER = 60, 61, 62, 58, 62
FC_DL, FC_DH = 0x08, 0x0A


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
                block = ("module",)
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


# ------------------------------------------------------------------ the harness

class Slaves:
    def __init__(self, tmp, config):
        self.path = os.path.join(tmp, "slaves.json")
        with open(self.path, "w") as f:
            json.dump(config, f)
        self.err = open(os.path.join(tmp, "harness.log"), "w")
        self.proc = subprocess.Popen([HARNESS, self.path], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.err, text=True, bufsize=1)
        self.lines = []
        # Read from the descriptor directly: select() and a buffered reader do not mix.
        self.partial = b""

    def read_until(self, predicate, timeout=WAIT, since=0):
        """The first line from index `since` on that matches, reading more as they come."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in self.lines[since:]:
                if predicate(line):
                    return line
            fd = self.proc.stdout.fileno()
            r, _, _ = select.select([fd], [], [], max(0.0, end - time.monotonic()))
            if r:
                chunk = os.read(fd, 4096)
                if not chunk:
                    break
                self.partial += chunk
                *done, self.partial = self.partial.split(b"\n")
                self.lines += [d.decode().strip() for d in done]
        raise AssertionError("harness: no matching line in %s" % self.lines)

    def command(self, text):
        """Sends a command and waits for its "ok" (tests/gsd_slave/pty_slaves.cpp)."""
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()
        self.read_until(lambda line: line == "ok " + text or line.startswith("error "))
        if ("ok " + text) not in self.lines:
            raise AssertionError("harness refused %r: %s" % (text, self.lines))
        self.lines.remove("ok " + text)  # a command may be sent again

    def stop(self):
        if self.proc.poll() is None:
            self.proc.stdin.write("quit\n")
            self.proc.stdin.flush()
            try:
                self.proc.wait(timeout=WAIT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdin.close()
        self.proc.stdout.close()
        self.err.close()


def response_fc(r):
    if r[0] == SD2:
        return r[6] & 0x0F
    if r[0] == SD3:
        return r[3] & 0x0F
    return r[3] & 0x0F  # SD1


class GenericSlavesOverPty(unittest.TestCase):
    COUPLER, SIMOCODE = 9, 8
    COUPLER_MODULES = ["4 Bytes Output consistent", "2 Bytes Input", "1 Byte Output"]

    @classmethod
    def setUpClass(cls):
        cls.coupler = Gsd(os.path.join(CORPUS, "SIEM8070.GSD"))
        cls.simocode = Gsd(os.path.join(CORPUS, "SIEM8031.GSE"))

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="candp2-gsd-slave-")
        self.link = os.path.join(self.tmp, "pb")
        config = {
            "profibus": {"port": "pty:" + self.link, "baud": 19200, "role": "slaves"},
            "buses": {"can0": {"type": "virtual"}},
            "gateways": [{"address": 3, "bus": "can0",
                          "slots": [{"io": "output", "address": 0, "length": 1}]}],
            "slaves": [
                {"address": self.COUPLER, "gsd": os.path.join(CORPUS, "SIEM8070.GSD"),
                 "modules": self.COUPLER_MODULES},
                {"address": self.SIMOCODE, "gsd": os.path.join(CORPUS, "SIEM8031.GSE"),
                 "modules": ["Basic Type 2"]},
            ],
        }
        self.slaves = Slaves(self.tmp, config)
        self.slaves.read_until(lambda line: line.startswith("ready "))
        self.master = FdlMaster(self.link)

    def tearDown(self):
        self.master.close()
        self.slaves.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def diag(self, station):
        """Slave_Diag: SD2, or SD3 when the SAPs and data are exactly 8 bytes (a 6-byte
        diagnosis; IEC 61158-4-3 SD3 carries a fixed 8-byte information field)."""
        r = self.master.srd(station, b"", dsap=SAP_DIAG)
        assert r, "no answer to Slave_Diag"
        if r[0] == SD3:
            self.assertEqual((r[1] & 0x80, r[2] & 0x80, r[4], r[5]), (0x80, 0x80, 62, SAP_DIAG))
            return r[6:12]
        self.assertEqual(r[0], SD2, r.hex(" "))
        return r[9:-2]  # after 68 LE LEr 68 DA SA FC DSAP SSAP

    def parameterize(self, station, prm, cfg):
        assert self.master.fdl_status(station) is not None, "no FDL_Status answer"
        self.diag(station)
        self.assertEqual(self.master.set_prm(station, prm), bytes([SC]))
        self.assertEqual(self.master.chk_cfg(station, cfg), bytes([SC]))
        return self.diag(station)

    def exchange(self, station, outputs):
        r, inputs = self.master.data_exchange(station, outputs)
        return response_fc(r), inputs

    def global_control(self, station, control):
        # SDN high (FC 0x46), DSAP 58: no answer (IEC 61158-6-3 Global_Control).
        # The next request on the line is handled after it: the slave reads the line in order.
        os.write(self.master.fd, sd2(station, self.master.address, 0x46, bytes([control, 0]),
                                     SAP_GC, SAP_MASTER))

    def test_data_exchange_with_its_own_module_list(self):
        c = self.coupler
        diag = self.parameterize(self.COUPLER, c.set_prm(), c.chk_cfg(self.COUPLER_MODULES))
        self.assertEqual(diag.hex(" "), "00 0c 00 02 80 70")  # WD_On, master 2, ident 8070
        fc, inputs = self.exchange(self.COUPLER, bytes([0x11, 0x22, 0x33, 0x44, 0x55]))
        self.assertEqual(inputs, bytes(2))
        self.slaves.read_until(lambda line: line == "outputs 9 11 22 33 44 55")
        self.slaves.command("inputs 9 A5 5A")
        end = time.monotonic() + WAIT
        while inputs != bytes([0xA5, 0x5A]) and time.monotonic() < end:
            fc, inputs = self.exchange(self.COUPLER, bytes([0x11, 0x22, 0x33, 0x44, 0x55]))
        self.assertEqual(inputs, bytes([0xA5, 0x5A]))
        self.assertEqual(fc, FC_DL)

    def test_other_module_list_is_cfg_fault(self):
        c = self.coupler
        diag = self.parameterize(self.COUPLER, c.set_prm(),
                                 c.chk_cfg(["4 Bytes Output consistent", "2 Bytes Input"]))
        self.assertEqual(diag[0], 0x06)  # Station_Not_Ready + Cfg_Fault

    def test_value_out_of_range_is_prm_fault(self):
        s = self.simocode
        # "Class" (ExtUserPrmData 21, Unsigned8 5-30) at user byte 15.
        diag = self.parameterize(self.SIMOCODE, s.set_prm(values={15: 40}),
                                 s.chk_cfg(["Basic Type 2"]))
        self.assertEqual(diag[0], 0x42)  # Station_Not_Ready + Prm_Fault
        diag = self.parameterize(self.SIMOCODE, s.set_prm(values={15: 20}),
                                 s.chk_cfg(["Basic Type 2"]))
        self.assertEqual(diag.hex(" "), "00 0c 00 02 80 31")

    def test_sync_refused_by_one_honoured_by_the_other(self):
        s, c = self.simocode, self.coupler
        diag = self.parameterize(self.SIMOCODE, s.set_prm(sync=True), s.chk_cfg(["Basic Type 2"]))
        self.assertEqual(diag[0], 0x12)  # Station_Not_Ready + Not_Supported
        diag = self.parameterize(self.COUPLER, c.set_prm(sync=True),
                                 c.chk_cfg(self.COUPLER_MODULES))
        self.assertEqual(diag[0], 0x00)
        self.exchange(self.COUPLER, bytes([1, 1, 1, 1, 1]))
        self.slaves.read_until(lambda line: line == "outputs 9 01 01 01 01 01")
        self.global_control(self.COUPLER, 0x20)  # Sync
        self.assertTrue(self.diag(self.COUPLER)[1] & 0x20)  # Sync_Mode
        self.exchange(self.COUPLER, bytes([2, 2, 2, 2, 2]))
        self.exchange(self.COUPLER, bytes([2, 2, 2, 2, 2]))
        # The harness reports outputs before it answers; "ping" collects everything up to now.
        self.slaves.command("ping")
        self.assertNotIn("outputs 9 02 02 02 02 02", self.slaves.lines)  # held until the next Sync
        self.global_control(self.COUPLER, 0x20)
        self.slaves.read_until(lambda line: line == "outputs 9 02 02 02 02 02")

    def test_leaves_the_bus_and_comes_back(self):
        c = self.coupler
        self.parameterize(self.COUPLER, c.set_prm(watchdog_ms=200), c.chk_cfg(self.COUPLER_MODULES))
        mark = len(self.slaves.lines)
        self.slaves.command("offline 9")
        self.assertIsNone(self.master.srd(self.COUPLER, b"", dsap=SAP_DIAG))
        # Its watchdog (200 ms) expired meanwhile.
        self.slaves.read_until(lambda line: line == "state 9 Wait_Prm", since=mark)
        self.slaves.command("online 9")
        diag = self.parameterize(self.COUPLER, c.set_prm(), c.chk_cfg(self.COUPLER_MODULES))
        self.assertEqual(diag[0], 0x00)

    def test_diagnosis_alarm_is_announced_with_dh(self):
        c = self.coupler
        self.parameterize(self.COUPLER, c.set_prm(), c.chk_cfg(self.COUPLER_MODULES))
        fc, _ = self.exchange(self.COUPLER, bytes(5))
        self.assertEqual(fc, FC_DL)
        self.slaves.command("diag 9 42 43")
        end = time.monotonic() + WAIT
        while fc != FC_DH and time.monotonic() < end:
            fc, _ = self.exchange(self.COUPLER, bytes(5))
        self.assertEqual(fc, FC_DH)
        diag = self.diag(self.COUPLER)
        self.assertEqual(diag.hex(" "), "08 0c 00 02 80 70 03 42 43")  # Ext_Diag, device block


def main():
    global HARNESS
    parser = argparse.ArgumentParser()
    parser.add_argument("--harness", required=True)
    args, rest = parser.parse_known_args()
    HARNESS = os.path.abspath(args.harness)
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
