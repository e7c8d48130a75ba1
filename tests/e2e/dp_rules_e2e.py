"""The DP slave rules of docs/dp-slave.md "Lock" and "Wrong output length", seen from two
independent FDL masters over a pty (pytest on the candp2 package; ctest e2e_dp_rules).

candp2d runs in role `"slaves"` on `pty:<tmp>/pb` with the CAN-DP/2 gateway 3 (the manual §5.1.4
slots) and a generic slave at 8 from the project's example GSD (gsd/examples/CDP20C2D.GSD, modules
"8 DI", "8 DO": one output byte). The test's FDL masters 2 and 5 (the one of profibus_e2e.py;
Set_Prm and Chk_Cfg of the generic slave from the GSD reader of gsd_slave_e2e.py) share the link.
Each rule is shown on both kinds of slave, through the telegrams and through candp2d's own view
(Modbus):

  * Lock: master 2 parameterizes the station with Lock_Req; master 5's Set_Prm with Lock_Req is
    acknowledged (SC) but not taken: the state stays Data_Exch, master 5's Slave_Diag shows master
    2 in byte 3, master 2's next Data_Exchange is answered with data.
  * Lock_Req = Unlock_Req = 0 from master 2 (watchdog off in the telegram): acknowledged, the
    station stays in Data_Exch and keeps its watchdog (WD_On in the diagnosis).
  * Data_Exchange with the wrong number of output bytes: RS, the station leaves Data_Exch for
    Wait_Prm and asks to be parameterized (Station_Not_Ready, Prm_Req); a parameterization brings
    it back.
"""

import os

import pytest

from gsd_slave_e2e import Gsd, response_fc
from profibus_e2e import CFG_514, SC, FdlMaster, slots_514

WAIT = 10.0
GATEWAY, IO = 3, 8
MASTER, OTHER = 2, 5
IO_MODULES = ["8 DI", "8 DO"]
ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
IO_GSD = os.path.join(ROOT, "gsd", "examples", "CDP20C2D.GSD")
# The Set_Prm of the capture in docs/profibus.md (Lock_Req, WD_On) with a 2.55 s watchdog
# (WD_Fact_1 = 255): the test's pauses never reach it.
PRM_GATEWAY = bytes.fromhex("88 FF 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF")
FC_RS = 0x03  # FDL response "no service activated" (docs/profibus.md)
STATION_NOT_READY, PRM_REQ, WD_ON = 0x02, 0x01, 0x08


def line_config(link):
    return {
        "profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
        "buses": {"can0": {"type": "virtual"}},
        "gateways": [{"name": "gw3", "address": GATEWAY, "bus": "can0", "slots": slots_514()}],
        "slaves": [{"name": "io", "address": IO, "gsd": IO_GSD, "modules": IO_MODULES,
                    "field_unit": 100 + IO}],
        "log": {"level": "debug"},
    }


class Station:
    """One station under test: how master 2 parameterizes it and what it exchanges."""

    def __init__(self, address, face, prm, cfg, outputs, wrong):
        self.address, self.face = address, face
        self.prm, self.cfg, self.outputs = prm, cfg, outputs
        self.wrong = wrong  # outputs of the wrong length


@pytest.fixture
def line(candp2d, tmp_path):
    link = str(tmp_path / "pb")
    daemon = candp2d(line_config(link))
    assert os.path.islink(link), "no pty link at " + link
    masters = {MASTER: FdlMaster(link, MASTER), OTHER: FdlMaster(link, OTHER)}
    io = Gsd(IO_GSD)
    stations = {
        "gateway": Station(GATEWAY, daemon.gateway(GATEWAY), PRM_GATEWAY, CFG_514, bytes(6),
                           bytes(5)),
        "generic": Station(IO, daemon.slave("io"), io.set_prm(watchdog_ms=2550),
                           io.chk_cfg(IO_MODULES), bytes(1), bytes(2)),
    }
    yield daemon, masters, stations
    for m in masters.values():
        m.close()


def diag(master, station):
    """Slave_Diag: the gateway answers SD2 (11 bytes), a 6-byte diagnosis travels as SD3."""
    r = master.srd(station, b"", dsap=60)
    assert r, "no answer to Slave_Diag"
    return r[6:12] if r[0] == 0xA2 else r[9:-2]


def in_data_exch(master, st):
    assert master.fdl_status(st.address) is not None, "no FDL_Status answer"
    diag(master, st.address)
    assert master.set_prm(st.address, st.prm) == bytes([SC])
    assert master.chk_cfg(st.address, st.cfg) == bytes([SC])
    d = diag(master, st.address)
    assert not d[0] & STATION_NOT_READY and d[3] == master.address, d.hex(" ")
    r, _ = master.data_exchange(st.address, st.outputs)
    assert response_fc(r) != FC_RS, r.hex(" ")
    st.face.wait_until(lambda s: s.state == "Data_Exch", timeout=WAIT)


@pytest.mark.parametrize("kind", ["gateway", "generic"])
def test_a_locked_station_ignores_another_masters_parameterization(line, kind):
    daemon, masters, stations = line
    st, m2, m5 = stations[kind], masters[MASTER], masters[OTHER]
    in_data_exch(m2, st)
    other = bytes([st.prm[0], 0x1E]) + st.prm[2:]  # Lock_Req, another watchdog
    assert m5.fdl_status(st.address) is not None
    assert m5.set_prm(st.address, other) == bytes([SC])  # acknowledged on the line ...
    d = diag(m5, st.address)
    assert d[3] == MASTER, d.hex(" ")  # ... not taken: the lock holder in byte 3
    assert not d[0] & STATION_NOT_READY and not d[1] & PRM_REQ, d.hex(" ")
    assert m5.chk_cfg(st.address, st.cfg) == bytes([SC])
    r, _ = m2.data_exchange(st.address, st.outputs)
    assert response_fc(r) != FC_RS, "master 2 refused after master 5's Set_Prm: " + r.hex(" ")
    assert st.face.state == "Data_Exch"
    assert st.face.diagnosis.master == MASTER
    assert "ignored: locked by master 2" in daemon.log


@pytest.mark.parametrize("kind", ["gateway", "generic"])
def test_set_prm_without_lock_req_keeps_data_exch_and_watchdog(line, kind):
    daemon, masters, stations = line
    st, m2 = stations[kind], masters[MASTER]
    in_data_exch(m2, st)
    no_lock = bytes([0x00, 1, 1]) + st.prm[3:]  # Lock_Req = Unlock_Req = 0, WD_On clear
    assert m2.set_prm(st.address, no_lock) == bytes([SC])
    d = diag(m2, st.address)
    assert not d[0] & STATION_NOT_READY and d[1] & WD_ON, d.hex(" ")
    r, _ = m2.data_exchange(st.address, st.outputs)
    assert response_fc(r) != FC_RS, r.hex(" ")
    assert st.face.state == "Data_Exch"


@pytest.mark.parametrize("kind", ["gateway", "generic"])
def test_wrong_output_length_leaves_data_exch(line, kind):
    daemon, masters, stations = line
    st, m2 = stations[kind], masters[MASTER]
    in_data_exch(m2, st)
    r, _ = m2.data_exchange(st.address, st.wrong)  # 5 bytes for 6, 2 bytes for 1
    assert response_fc(r) == FC_RS, r.hex(" ")
    d = diag(m2, st.address)
    assert d[0] & STATION_NOT_READY and d[1] & PRM_REQ, d.hex(" ")
    assert d[3] == MASTER, d.hex(" ")
    st.face.wait_until(lambda s: s.state == "Wait_Prm", timeout=WAIT)
    r, _ = m2.data_exchange(st.address, st.outputs)  # the right length: parameterize first
    assert response_fc(r) == FC_RS, r.hex(" ")
    assert "leaves Data_Exch" in daemon.log
    in_data_exch(m2, st)  # and back
