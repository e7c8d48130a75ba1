"""The line statistics and line faults of candp2.Line (docs/python.md, docs/profibus.md "Line
statistics"), read from a status document of the shape GET /api/v1/status gives, and the Modbus
writes of inject() and noise() (docs/modbus.md), without a daemon."""

from __future__ import annotations

import copy
from typing import Any, Sequence, cast

import pytest

from candp2 import Connection, Line, LineFault, LineStation, LiveList, RegisterMap

STATUS: dict[str, Any] = {
    "baud": 1500000,
    "bus_cycle_us": {"last": 1200, "min": 1100, "mean": 1180, "max": 1900, "cycles": 420},
    "retries": 7, "gap_polls": 3,
    "illegals_unattributed": 2,
    "live_list": {"ok": [3, 4], "missing": [5], "phantom": [9]},
    "stations": [
        {"address": 3, "live": "ok", "lost": 0, "syncs": 1, "repeats": 6, "repeats_max": 1,
         "illegals": 5, "diagnostics": 2,
         "fault": {"kind": "corrupt", "remaining": 0, "every": 2, "remaining_ms": 15}},
        {"address": 4, "live": "ok", "lost": 0, "syncs": 1, "repeats": 0, "repeats_max": 0,
         "illegals": 0, "diagnostics": 2, "fault": None},
        {"address": 5, "live": "missing", "lost": 1, "syncs": 1, "repeats": 4, "repeats_max": 1,
         "illegals": 0, "diagnostics": 2, "fault": None},
        {"address": 9, "live": "phantom", "lost": 0, "syncs": 0, "repeats": 0, "repeats_max": 0,
         "illegals": 1, "diagnostics": 0, "fault": None},
    ],
    "noise_remaining_ms": 12,
}


def test_the_station_counters_are_the_documents() -> None:
    line = Line.from_status(STATUS)
    s = line.station(3)
    assert (s.address, s.live) == (3, "ok")
    assert (s.repeats, s.lost, s.syncs, s.repeats_max, s.illegals, s.diagnostics) == \
        (6, 0, 1, 1, 5, 2)
    assert s.fault == LineFault("corrupt", 0, 2, 15)
    assert line.station(5).lost == 1 and line.station(5).live == "missing"
    assert line.station(4).fault is None
    # The counters are whatever numbers the document gives a station, in its order.
    assert list(s.counters) == ["lost", "syncs", "repeats", "repeats_max", "illegals",
                                "diagnostics"]
    assert line.live_list == LiveList((3, 4), (5,), (9,))
    assert (line.illegals_unattributed, line.noise_remaining_ms) == (2, 12)
    assert line.bus_cycle_us is not None and line.bus_cycle_us.max == 1900
    assert (line.baud, line.retries, line.gap_polls) == (1500000, 7, 3)


def test_a_counter_the_document_adds_is_an_attribute_and_a_missing_one_says_so() -> None:
    status = copy.deepcopy(STATUS)
    status["stations"][0]["tokens_lost"] = 4
    s = Line.from_status(status).station(3)
    assert s.tokens_lost == 4
    with pytest.raises(AttributeError, match=r"no counter 'repeat'.*repeats"):
        s.repeat


def test_an_address_the_line_does_not_know_is_none_with_zero_counters() -> None:
    s = Line.from_status(STATUS).station(60)
    assert (s.address, s.live, s.fault) == (60, "none", None)
    assert s.counters == dict.fromkeys(Line.from_status(STATUS).station(3).counters, 0)
    assert s.repeats == 0


def test_role_master_has_no_bus_cycle() -> None:
    """profibus.role "master": the analyser's figures, no bus cycle, retries or GAP polls."""
    status = {k: v for k, v in STATUS.items()
              if k not in ("bus_cycle_us", "retries", "gap_polls")}
    line = Line.from_status(status)
    assert (line.bus_cycle_us, line.retries, line.gap_polls) == (None, None, None)
    assert line.station(3).repeats == 6


def test_stations_compare_by_value() -> None:
    a, b = Line.from_status(STATUS), Line.from_status(copy.deepcopy(STATUS))
    assert a == b and a.station(3) == b.station(3) != a.station(4)
    assert isinstance(a.station(3), LineStation)
    assert "repeats=6" in repr(a.station(3))


# ---- inject() and noise(): the Modbus line fault registers ----------------------------------

class FakeModbus:
    def __init__(self) -> None:
        self.writes: list[tuple[int, list[int], int]] = []

    def write_registers(self, address: int, values: Sequence[int], unit: int) -> None:
        self.writes.append((address, list(values), unit))

    def write_register(self, address: int, value: int, unit: int) -> None:
        self.writes.append((address, [value], unit))


class FakeConnection:
    def __init__(self, register_map: RegisterMap) -> None:
        self.register_map = register_map
        self.modbus = FakeModbus()


@pytest.fixture(scope="module")
def register_map(candp2_binary: str) -> RegisterMap:
    return RegisterMap.from_binary(candp2_binary)


def faked(register_map: RegisterMap) -> tuple[Line, FakeModbus]:
    connection = FakeConnection(register_map)
    return Line.from_status(STATUS, cast(Connection, connection)), connection.modbus


def test_inject_writes_the_fault_in_one_request(register_map: RegisterMap) -> None:
    line, modbus = faked(register_map)
    r, kinds = register_map.line_fault_registers, register_map.line_fault_kinds
    line.inject(3, "corrupt", count=5, every=2)
    line.inject(4, "silent", for_ms=20)
    line.inject(5, "late")
    line.inject(3, "none")
    assert modbus.writes == [
        (r["kind"], [kinds.index("corrupt"), 5, 2, 0], 3),
        (r["kind"], [kinds.index("silent"), 0, 1, 20], 4),
        (r["kind"], [kinds.index("late"), 1, 1, 0], 5),
        (r["kind"], [kinds.index("none"), 1, 1, 0], 3),
    ]
    # docs/modbus.md: kind, count, every, for_ms follow each other; the kinds by their code.
    assert [r[n] for n in ("kind", "count", "every", "for_ms")] == \
        list(range(r["kind"], r["kind"] + 4))
    assert kinds == ("none", "corrupt", "silent", "late", "double_address")


def test_noise_writes_the_line_register(register_map: RegisterMap) -> None:
    line, modbus = faked(register_map)
    line.noise(for_ms=20)
    assert modbus.writes == [(register_map.line_fault_registers["noise_for_ms"], [20], 3)]


def test_bad_faults_are_refused_before_anything_is_written(register_map: RegisterMap) -> None:
    line, modbus = faked(register_map)
    with pytest.raises(ValueError, match="expected one of none, corrupt, silent"):
        line.inject(3, "garbled")
    with pytest.raises(ValueError, match="count or for_ms, not both"):
        line.inject(3, "corrupt", count=2, for_ms=10)
    with pytest.raises(ValueError, match=r"every 0: expected 1\.\.65535"):
        line.inject(3, "corrupt", every=0)
    with pytest.raises(ValueError, match="for_ms 70000"):
        line.noise(for_ms=70000)
    assert modbus.writes == []


def test_a_line_not_read_from_a_daemon_cannot_inject() -> None:
    with pytest.raises(RuntimeError, match="read daemon.line"):
        Line.from_status(STATUS).inject(3, "corrupt")
