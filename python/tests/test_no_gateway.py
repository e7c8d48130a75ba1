"""A line of generic slaves alone (docs/slaves.md "A line of generic slaves alone"): the Daemon,
its reports and the faces with no gateway and no CAN bus; neither gateways nor slaves is a
ConfigError with the JSON path."""

import json
from typing import Any, Callable

import pytest

from candp2 import ConfigError, Daemon

from plants import ROOT

Factory = Callable[..., Daemon]

COMPACT_GSD = str(ROOT / "config" / "gsd" / "CDP2C0A.GSD")

SLAVES_ONLY: dict[str, Any] = {
    "master": {"address": 1, "cycle_ms": 2, "retry_ms": 100},
    "slaves": [
        {"name": "in1", "address": 4, "gsd": COMPACT_GSD, "field_unit": 104,
         "watchdog_ms": 200, "input_address": 0, "output_address": 0},
        {"name": "in2", "address": 5, "gsd": COMPACT_GSD, "field_unit": 105,
         "watchdog_ms": 200, "input_address": 8, "output_address": 8},
    ],
}


def test_the_faces_without_a_gateway(candp2d: Factory) -> None:
    daemon = candp2d(SLAVES_ONLY)
    assert daemon.socketcand == {}                        # no bus, no export
    assert daemon.gateways() == []
    assert [s.name for s in daemon.slaves()] == ["in1", "in2"]
    in1 = daemon.slave("in1")
    in1.wait_until(lambda s: s.state == "Data_Exch")
    # Units 0 and 255 address the first station: here the first slave (docs/modbus.md).
    m = daemon.register_map
    first = m.slave(4)
    assert first is not None and set(m.first_gateway_units) < set(first.units)
    dp_address = m.fields["dp_address"].register
    for unit in m.first_gateway_units:
        assert daemon.modbus.read_registers("input_registers", dp_address, 1, unit) == [4]
    # HTTP: no gateway, no bus, both slaves.
    doc = daemon.http_status()
    assert doc["gateways"] == [] and doc["buses"] == []
    assert [s["name"] for s in doc["slaves"]] == ["in1", "in2"]
    # What a failing test shows: the slaves, nothing about gateways or buses.
    report = daemon.report()
    assert "slave 4 (in1): Data_Exch" in report and "slave 5 (in2)" in report
    assert "unavailable" not in report
    status_line = daemon.status_line
    assert status_line is not None and "2 generic slaves" in status_line


def test_neither_gateways_nor_slaves_is_refused(candp2_binary: str) -> None:
    empty = json.loads(json.dumps(SLAVES_ONLY))
    empty["slaves"] = []
    with pytest.raises(ConfigError) as info:
        Daemon(empty, candp2_binary)
    assert info.value.path == "$.gateways"
    assert "or generic DP-V0 slaves in $.slaves" in info.value.message
