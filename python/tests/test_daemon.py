"""candp2.Daemon: free ports learnt from READY=1, errors that carry the log, stop, connect()."""

import json
import os
import re
import signal
from pathlib import Path
from typing import Callable

import pytest

import candp2
from candp2 import ConfigError, Daemon, DaemonError

from plants import MANUAL_514

Factory = Callable[..., Daemon]


def test_ports_come_from_ready(candp2d: Factory) -> None:
    a, b = candp2d(MANUAL_514), candp2d(MANUAL_514)
    assert a.modbus_address != b.modbus_address
    assert a.modbus_address[0] == "127.0.0.1" and a.modbus_address[1] > 0
    assert a.http_url is not None and a.http_url.startswith("http://127.0.0.1:")
    assert set(a.socketcand) == {"can0"}  # the virtual bus gets an export
    # The log says where it listens, and it matches what READY=1 said.
    line = re.search(r"ready: modbus 127\.0\.0\.1:(\d+), http 127\.0\.0\.1:(\d+), bus can0 "
                     r"socketcand 127\.0\.0\.1:(\d+)", a.log)
    assert line, a.log
    assert int(line.group(1)) == a.modbus_address[1]
    assert int(line.group(3)) == a.socketcand["can0"][1]
    assert a.config["modbus"]["listen"] == "127.0.0.1:0"


def test_refused_configuration_raises_with_the_json_path(candp2_binary: str) -> None:
    bad = json.loads(json.dumps(MANUAL_514))
    bad["gateways"][0]["bus"] = "can9"
    with pytest.raises(ConfigError) as info:
        Daemon(bad, candp2_binary)
    assert info.value.path == "$.gateways[0].bus"
    assert 'unknown bus "can9"' in info.value.message
    assert "$.gateways[0].bus" in str(info.value)


def test_failed_start_carries_the_log_tail(candp2_binary: str, tmp_path: Path) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    # A folder that cannot be made: its "parent" is a file (docs/daemon.md "Started by hand").
    (tmp_path / "a-file").write_text("")
    config["log"] = {"can_log": str(tmp_path / "a-file" / "logs" / "can.log")}
    with pytest.raises(DaemonError) as info:
        Daemon(config, candp2_binary)
    assert info.value.returncode == 1
    assert "before it was ready" in str(info.value)
    assert "--- candp2d log (last lines) ---" in str(info.value)
    assert "can.log: cannot create its folder" in str(info.value)


def test_the_folders_of_its_files_are_made(candp2d: Factory, tmp_path: Path) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["log"] = {"can_log": str(tmp_path / "logs" / "candp2" / "can.log")}
    config["state_file"] = str(tmp_path / "state" / "state.json")
    daemon = candp2d(config)
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    assert (tmp_path / "logs" / "candp2" / "can.log").is_file()
    assert (tmp_path / "state").is_dir() and "state file" not in daemon.log


def test_a_state_file_that_cannot_be_written_is_one_warning(
        candp2d: Factory, tmp_path: Path) -> None:
    (tmp_path / "a-file").write_text("")
    config = json.loads(json.dumps(MANUAL_514))
    config["state_file"] = str(tmp_path / "a-file" / "state.json")
    daemon = candp2d(config)
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    lines = [line for line in daemon.log.splitlines() if "state file" in line]
    assert len(lines) == 1 and "cannot create its folder" in lines[0], lines
    assert "not kept across restarts" in lines[0]


def test_a_daemon_that_dies_is_reported_with_its_log(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    daemon.kill()
    with pytest.raises(DaemonError, match=r"candp2d exited with status -9") as info:
        gw.counters
    assert "[candp2d] ready" in str(info.value)
    daemon.stop(check=False)


def test_stop_is_sigterm_and_exit_0(candp2_binary: str) -> None:
    with Daemon(MANUAL_514, candp2_binary) as daemon:
        pid = daemon.pid
        assert pid is not None
    assert daemon.returncode == 0
    assert daemon.pid is None
    assert "[candp2d] stopped" in daemon.log
    with pytest.raises(OSError):
        os.kill(pid, 0)


def test_sighup_and_relative_paths(candp2_binary: str, tmp_path: Path) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["log"] = {"can_log": "can.log"}  # relative to the configuration file
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(config))
    with Daemon(path, candp2_binary) as daemon:
        assert daemon.config["log"]["can_log"] == str(tmp_path / "can.log")
        daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
        (tmp_path / "can.log").rename(tmp_path / "can.log.1")
        daemon.signal(signal.SIGHUP)
        daemon.gateway(5).wait_until(lambda g: (tmp_path / "can.log").exists())


def test_connect_attaches_to_a_running_daemon(candp2d: Factory, candp2_binary: str,
                                              tmp_path: Path) -> None:
    daemon = candp2d(MANUAL_514)
    assert daemon.http_url is not None
    modbus = "%s:%d" % daemon.modbus_address
    http = daemon.http_url[len("http://"):]
    socketcand = "%s:%d" % daemon.socketcand["can0"]
    with candp2.connect(modbus, http=http, socketcand=socketcand, binary=candp2_binary) as c:
        gw, can0 = c.gateway(5), c.bus("can0")  # the bus first: it sees what is sent after
        gw.wait_until(lambda g: g.state == "Data_Exch")
        assert [g.address for g in c.gateways()] == [5]
        assert gw.slot(1).description.startswith("slot 1: output Q172..177 (6 bytes) to CAN "
                                                 "0x309")
        gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
        can0.expect(0x309, bytes.fromhex("0B0A0F0E0D0C"))
    # With the configuration file it knows the gateways' names and slots without HTTP.
    path = tmp_path / "plant.json"
    path.write_text(json.dumps(daemon.config))
    with candp2.connect(modbus, binary=candp2_binary, config=path) as c:
        assert c.gateway("gw5").address == 5
        assert c.gateway(5).slot(0).plc == "I172"


def test_drives_get_units_and_other_files_stay(candp2_binary: str, tmp_path: Path) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["drives"] = [{"name": "a", "bus": "can0"},
                        {"name": "b", "bus": "can0", "rx_id": "0x202", "tx_id": "0x182",
                         "modbus_unit": 254}]
    with Daemon(config, candp2_binary) as daemon:
        units = {d.name: d.unit for d in daemon.register_map.drives}
        assert units["b"] == 254 and units["a"] is not None and units["a"] != 254
        assert units["a"] not in {g.dp_address for g in daemon.register_map.gateways}


def test_status_lines_are_read_after_ready(candp2d: Factory) -> None:
    """After READY=1 the Daemon keeps reading its NOTIFY_SOCKET: STATUS= changes reach it and
    candp2d never meets a full or missing socket."""
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.wait_until(lambda g: daemon.status_line == "1 gateway, 1 in Data_Exch, 1 Modbus client")
    assert "sd_notify" not in daemon.log


def test_find_example_in_the_checkout_and_beside_an_installed_candp2d(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = Path(candp2.__file__).resolve().parent.parent.parent
    assert candp2.find_example("plc-line.json") == root / "config" / "plc-line.json"
    assert candp2.find_example("scenarios/plc-line.json").is_file()
    # Installed (the package not in a checkout): PREFIX/share/candp2/examples beside
    # PREFIX/bin/candp2d.
    monkeypatch.setattr("candp2.binary._checkout", lambda: None)
    (tmp_path / "bin").mkdir()
    binary = tmp_path / "bin" / "candp2d"
    binary.write_text("#!/bin/sh\n")
    binary.chmod(0o755)
    examples = tmp_path / "share" / "candp2" / "examples"
    examples.mkdir(parents=True)
    (examples / "plc-line.json").write_text("{}")
    assert candp2.find_example("plc-line.json", binary) == examples / "plc-line.json"
    with pytest.raises(candp2.Candp2Error, match="no example nothing.json \\(tried .*examples"):
        candp2.find_example("nothing.json", binary)


def test_find_example_beside_a_candp2d_of_a_build_tree(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The package installed (not in a checkout) and candp2d from a build tree (pytest
    --candp2d build/bin/candp2d): the examples are in the source tree that build tree's
    CMakeCache.txt names, and $CANDP2_EXAMPLES comes first."""
    monkeypatch.setattr("candp2.binary._checkout", lambda: None)
    monkeypatch.delenv("CANDP2_EXAMPLES", raising=False)
    source, build = tmp_path / "src", tmp_path / "build"
    (source / "config").mkdir(parents=True)
    (source / "config" / "demo.json").write_text("{}")
    (build / "bin").mkdir(parents=True)
    (build / "CMakeCache.txt").write_text(
        "# This is the CMakeCache file.\nCMAKE_HOME_DIRECTORY:INTERNAL=%s\n" % source)
    binary = build / "bin" / "candp2d"
    binary.write_text("#!/bin/sh\n")
    binary.chmod(0o755)
    assert candp2.find_example("demo.json", binary) == source / "config" / "demo.json"
    # What pytest --candp2d sets for the session: example() without a binary finds it too.
    monkeypatch.setattr("candp2.binary._session_binary", None)
    candp2.binary.set_session_binary(binary)
    assert candp2.example("demo.json") == source / "config" / "demo.json"
    with pytest.raises(candp2.Candp2Error, match="no example nothing.json \\(tried .*"
                                                 "build/share/candp2/examples/nothing.json, .*"
                                                 "src/config/nothing.json; \\$CANDP2_EXAMPLES"):
        candp2.example("nothing.json")
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "demo.json").write_text("{}")
    monkeypatch.setenv("CANDP2_EXAMPLES", str(mine))
    assert candp2.example("demo.json") == mine / "demo.json"
