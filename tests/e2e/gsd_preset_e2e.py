"""GSD preset modules over a pseudo-terminal (docs/slaves.md "Preset modules"; pytest on the
candp2 package, ctest e2e_gsd_preset_pty).

candp2d runs `profibus.role: "slaves"` on `pty:<tmp>/pb` with a generic slave from the project's
own test device tests/gsd_slave/data/preset_modular.gsd: a modular station whose "Head module"
(one status byte in) has Preset = 1, with FixPresetModules = 1. The configuration's `modules`
list only the user's modules, "Output 2 bytes" and "Input 1 byte", as a user of a configuration
tool picks them; candp2 puts the head module first, where the tools do.

The master is the independent FDL master and GSD reader of gsd_slave_e2e.py (none of our C++),
which builds its Chk_Cfg the way configuration tools do (pyprofibus, STEP 7): the preset modules
first, in GSD order, then the same user modules. Shown: it reaches Data_Exchange and the head
module's status byte travels in front of the input module's byte; a master that leaves the preset
module out of its Chk_Cfg gets a Cfg fault, and the slave's log names the entry.

Every wait is bounded; every daemon is stopped (the candp2d fixture).
"""

import os

import pytest

from gsd_slave_e2e import FC_DL, Gsd, Line, serve_line
from profibus_e2e import FdlMaster, slots_514

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
PRESET_GSD = os.path.join(ROOT, "tests", "gsd_slave", "data", "preset_modular.gsd")
IO, GATEWAY = 8, 3
USER_MODULES = ["Output 2 bytes", "Input 1 byte"]


def line_config(link):
    return {
        "profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
        "buses": {"can0": {"type": "virtual"}},
        "gateways": [{"name": "gw3", "address": GATEWAY, "bus": "can0", "slots": slots_514()}],
        "slaves": [{"name": "io8", "address": IO, "gsd": PRESET_GSD, "modules": USER_MODULES,
                    "field_unit": 100 + IO}],
        "log": {"level": "debug"},
    }


class PresetLine(Line):
    """The FDL master of gsd_slave_e2e.py against the one preset slave."""

    def __init__(self, daemon, link):  # pylint: disable=super-init-not-called
        self.daemon = daemon
        self.master = FdlMaster(link)
        self.io = daemon.slave("io8")


@pytest.fixture(scope="module")
def gsd():
    return Gsd(PRESET_GSD)


@pytest.fixture
def line(candp2d, tmp_path):
    line = serve_line(candp2d, tmp_path, line_config, PresetLine)
    yield line
    line.master.close()


def test_the_master_reads_the_preset_from_the_gsd(gsd):
    assert gsd.presets == ["Head module"]
    # Chk_Cfg as a tool builds it: the head module's entry (1 byte in, consistent) first.
    assert gsd.tool_chk_cfg(USER_MODULES) == gsd.modules["Head module"] + b"".join(
        gsd.modules[n] for n in USER_MODULES)


def test_data_exchange_with_the_preset_module_left_out_of_the_configuration(line, gsd):
    diag = line.parameterize(IO, gsd.set_prm(), gsd.tool_chk_cfg(USER_MODULES))
    assert diag.hex(" ") == "00 0c 00 02 0c 2e"  # Data_Exch, WD_On, master 2, ident 0C2E
    assert line.io.state == "Data_Exch"
    fc, inputs = line.exchange(IO, b"\x12\x34")
    assert fc == FC_DL and inputs == bytes(2)  # head status byte + the input module's byte
    line.io.wait_until(lambda s: s.field_outputs[0:2] == b"\x12\x34", timeout=10.0)
    # The field side: byte 0 is the head module's status, byte 1 the input module.
    line.io.field_inputs[0:2] = b"\xC3\x5A"
    fc, inputs = line.exchange_until(IO, b"\x12\x34", lambda fc, i: i == b"\xC3\x5A")
    assert inputs == b"\xC3\x5A"


def test_a_master_that_leaves_the_preset_out_gets_a_cfg_fault(line, gsd):
    diag = line.parameterize(IO, gsd.set_prm(), gsd.chk_cfg(USER_MODULES))
    assert diag[0] == 0x06  # Station_Not_Ready + Cfg_Fault
    assert line.io.state == "Wait_Prm"
    assert "Chk_Cfg entry 0: 21 (output 2 bytes), the slave has 90" in line.daemon.log
