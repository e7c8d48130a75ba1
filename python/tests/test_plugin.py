"""The pytest plugin's report on a failing test: the gateway's diagnosis, the bus's last frames
and the daemon's log tail; a daemon that died fails the teardown."""

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

from plants import EXAMPLE_GSD

PYTHON_DIR = Path(__file__).resolve().parent.parent

FAILING = textwrap.dedent('''
    PLANT = {"buses": {"can0": {"type": "virtual"}},
             "gateways": [{"address": 5, "bus": "can0", "slots": [
                 {"io": "output", "address": 0, "length": 2, "comment": "03,09,00"}]}]}

    def test_fails(candp2d):
        daemon = candp2d(PLANT)
        gw, can0 = daemon.gateway(5), daemon.bus("can0")
        gw.wait_until(lambda g: g.state == "Data_Exch")
        gw.outputs[0:2] = b"\\x12\\x34"
        can0.expect(0x309, b"\\x12\\x34")
        assert gw.state == "Wait_Prm"

    def test_dies(candp2d):
        candp2d(PLANT).kill()
''')


SLAVES = textwrap.dedent('''
    PLANT = {"buses": {"can0": {"type": "virtual"}},
             "gateways": [{"address": 5, "bus": "can0", "slots": [
                 {"io": "output", "address": 0, "length": 2, "comment": "03,09,00"}]}],
             "slaves": [{"name": "io1", "address": 8, "gsd": %r, "modules": ["8 DI", "8 DO"],
                         "field_unit": 108}]}

    def test_fails(candp2d):
        io1 = candp2d(PLANT).slave("io1")
        io1.wait_until(lambda s: s.state == "Data_Exch")
        io1.alarm(b"\\x42\\x43")
        io1.field_inputs[0] = 0x5A
        assert io1.state == "Wait_Prm"
''' % EXAMPLE_GSD)


LINE = textwrap.dedent('''
    PLANT = {"buses": {"can0": {"type": "virtual"}},
             "master": {"baud": 1500000},
             "gateways": [{"address": 5, "bus": "can0", "slots": [
                 {"io": "output", "address": 0, "length": 2, "comment": "03,09,00"}]}]}

    def test_fails(candp2d):
        daemon = candp2d(PLANT)
        daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
        daemon.line.inject(5, "corrupt", count=3, every=2)
        daemon.line.station(5).wait_until(lambda s: s.illegals == 3)
        # A fault that stays active: it spoils the next answer, then one in 65535.
        daemon.line.inject(5, "corrupt", count=65535, every=65535)
        daemon.line.station(5).wait_until(lambda s: s.illegals == 4)
        assert daemon.line.station(5).illegals == 0
''')


def run_pytest(tmp_path: Path, candp2_binary: str, *args: str, test: str = FAILING) -> str:
    (tmp_path / "test_report.py").write_text(test)
    env = dict(os.environ, PYTHONPATH=str(PYTHON_DIR))
    r = subprocess.run([sys.executable, "-m", "pytest", "-p", "candp2.pytest_plugin",
                        "-p", "no:cacheprovider", "--candp2d", candp2_binary, *args,
                        str(tmp_path / "test_report.py")],
                       capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    return r.stdout


def test_failure_report_sections(tmp_path: Path, candp2_binary: str) -> None:
    out = run_pytest(tmp_path, candp2_binary)
    assert "1 failed, 1 passed, 1 error" in out
    assert "candp2d 0 (modbus 127.0.0.1:" in out
    assert "gateway 5 (gw5): Data_Exch, master Data_Exch" in out
    assert "diagnosis: 00 04 00 01 04 A4" in out       # the decoded Slave_Diag
    assert "bus can0: last" in out and "309#1234" in out  # the bus's last frames
    assert "[candp2d] ready: modbus" in out             # the log's tail
    # test_dies: the teardown fails with the exit status and the log.
    assert "candp2d had exited with status -9 before stop()" in out


def test_failure_report_shows_the_slaves(tmp_path: Path, candp2_binary: str) -> None:
    out = run_pytest(tmp_path, candp2_binary, test=SLAVES)
    assert "1 failed" in out
    assert "slave 8 (io1): Data_Exch, master " in out
    # The whole diagnosis decoded: Ext_Diag and the alarm's device-related block.
    assert "diagnosis: 08 04 00 01 0C 2D 03 42 43; Ext_Diag; master 1; ident 0C2D; " \
        "device-related 42 43" in out
    assert "faults: on the bus, alarm 42 43" in out
    assert "field side (unit 108): inputs 5A, outputs 00" in out


def test_reports_under_xdist(tmp_path: Path, candp2_binary: str) -> None:
    out = run_pytest(tmp_path, candp2_binary, "-n", "2")
    assert "candp2d 0 (modbus 127.0.0.1:" in out and "309#1234" in out


def test_failure_report_shows_the_line(tmp_path: Path, candp2_binary: str) -> None:
    """The line section: baud rate and bus cycle, the live list, each station's counters in the
    table's order with its active fault."""
    out = run_pytest(tmp_path, candp2_binary, test=LINE)
    assert "1 failed" in out
    assert re.search(r"^line: 1500000 bit/s, bus cycle [\d.]+ (µs|ms) \(min .* over \d+ "
                     r"cycles\), \d+ retries, \d+ GAP polls$", out, re.M), out
    assert "\n  live list: ok 5; missing none; phantom none\n" in out
    assert re.search(r"^  station 5 \(ok\): lost 0, syncs 1, repeats 4, repeats_max 1, "
                     r"illegals 4, diagnostics \d+; fault corrupt \(\d+ left, every 65535\)$",
                     out, re.M), out
