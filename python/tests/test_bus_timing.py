"""A CAN bus in time seen from Python (docs/python.md "A bus in time"): daemon.bus(name)'s timing
read from /api/v1/status, CAN faults through the Modbus CAN fault block; an ideal bus says it
needs a bit rate."""

import json
import time
from typing import Any, Callable

import pytest

from candp2 import BusTiming, CanFaultInForce, Daemon, ModbusError, NodeCounters, NotTimed
from candp2.timing import can_fault_request

from plants import MANUAL_514, settled

Factory = Callable[..., Daemon]


def timed(bitrate: str) -> dict[str, Any]:
    config: dict[str, Any] = json.loads(json.dumps(MANUAL_514))
    config["buses"]["can0"]["bitrate"] = bitrate
    return config


STATUS_BUS = {
    "name": "can0", "type": "virtual", "bitrate": 125000, "frames": 3, "load_pct": 1.5,
    "timed_bitrate": 125000, "load": {"last_pct": 1.5, "max_pct": 2.25}, "frames_on_bus": 3,
    "tx_lost": 1,
    "identifiers": [
        {"id": 0x181, "ext": False, "rtr": False, "frames": 2, "period_ms": 10.0,
         "jitter_ms": 0.5, "latency_ms": {"last": 0.25, "mean": 0.5, "max": 0.75}},
        {"id": 0x181, "ext": False, "rtr": True, "frames": 1, "period_ms": 0.0,
         "jitter_ms": 0.0, "latency_ms": {"last": 0.0, "mean": 0.0, "max": 0.0}},
    ],
    "error_frames": 17,
    "nodes": [
        {"name": "gw:g5", "tec": 128, "rec": 0, "state": "error-passive"},
        {"name": "replay", "tec": 0, "rec": 16, "state": "ok"},
    ],
    "faults": [
        {"kind": "unplugged", "node": "gw:g5", "id": None, "ext": False, "remaining": 0,
         "every": 1, "remaining_ms": 40},
        {"kind": "error_frames", "node": None, "id": 0x181, "ext": False, "remaining": 3,
         "every": 2, "remaining_ms": 0},
    ],
}


def test_the_timing_is_the_status_documents() -> None:
    t = BusTiming.from_status(STATUS_BUS)
    assert t.timed_bitrate == 125000 and t.frames_on_bus == 3 and t.tx_lost == 1
    assert t.load.last_pct == 1.5 and t.load.max_pct == 2.25
    assert list(t.identifiers) == [0x181] and list(t.remote) == [0x181]
    i = t.identifiers[0x181]
    assert (i.frames, i.period_ms, i.jitter_ms) == (2, 10.0, 0.5)
    assert (i.latency_last_ms, i.latency_mean_ms, i.latency_max_ms) == (0.25, 0.5, 0.75)
    assert t.remote[0x181].remote and t.remote[0x181].frames == 1
    assert "181: 2 frames, period 10.000 ms" in t.describe()
    # docs/can-bus.md "Error confinement": the error frames and each node's counters.
    assert t.error_frames == 17
    assert list(t.nodes) == ["gw:g5", "replay"]
    assert t.nodes["gw:g5"] == NodeCounters(128, 0, "error-passive")
    assert t.nodes["replay"].rec == 16 and t.nodes["replay"].state == "ok"
    assert "17 error frames" in t.describe()
    assert "node gw:g5: TEC 128, REC 0, error-passive" in t.describe()
    # docs/can-bus.md "Seen from outside": the faults in force, what is left of each.
    assert t.faults == (CanFaultInForce("unplugged", "gw:g5", None, False, 0, 1, 40),
                        CanFaultInForce("error_frames", None, 0x181, False, 3, 2, 0))
    assert "fault unplugged gw:g5 (40 ms left)" in t.describe()
    assert "fault error_frames 181 (3 left, every 2)" in t.describe()
    ideal = {k: v for k, v in STATUS_BUS.items() if k in ("name", "type", "bitrate")}
    with pytest.raises(NotTimed, match=r"bus can0 is an ideal bus.*\"bitrate\""):
        BusTiming.from_status(ideal)


REGISTERS = {"kind": 8410, "count": 8411, "every": 8412, "for_ms": 8413}
KINDS = ("none", "error_frames", "unplugged", "wrong_bitrate", "noise")


def test_a_can_fault_is_one_write_from_the_kind_register() -> None:
    r = can_fault_request(REGISTERS, KINDS, [5, 7], "can0", "error_frames", count=3, every=2)
    assert (r.unit, r.register, r.values) == (5, 8410, (1, 3, 2, 0))
    r = can_fault_request(REGISTERS, KINDS, [5, 7], "can0", "unplugged", for_ms=200, gateway=7)
    assert (r.unit, r.values) == (7, (2, 0, 1, 200))
    r = can_fault_request(REGISTERS, KINDS, [5], "can0", "noise", for_ms=50)
    assert r.values == (4, 0, 1, 50)
    with pytest.raises(ValueError, match="expected one of none, error_frames"):
        can_fault_request(REGISTERS, KINDS, [5], "can0", "bitflip")
    with pytest.raises(ValueError, match="noise needs for_ms"):
        can_fault_request(REGISTERS, KINDS, [5], "can0", "noise")
    with pytest.raises(ValueError, match=r"no gateway 9 on bus can0 \(gateways: 5\)"):
        can_fault_request(REGISTERS, KINDS, [5], "can0", "unplugged", gateway=9)
    with pytest.raises(NotTimed, match="bus can1 has no gateway with a CAN fault block"):
        can_fault_request({}, (), [], "can1", "unplugged")


def test_daemon_bus_reads_the_bus_in_time(candp2d: Factory) -> None:
    daemon = candp2d(timed("125k"))
    gw = daemon.gateway(5)
    settled(gw)
    can0 = daemon.bus("can0")
    gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
    can0.expect(0x309, bytes.fromhex("0B0A0F0E0D0C"))
    assert can0.timed_bitrate == 125000
    t = can0.timing()
    assert t.frames_on_bus >= 2 and t.tx_lost == 0
    assert t.identifiers[0x309].frames >= 2, t.describe()
    assert t.identifiers[0x309].latency_max_ms >= 0.0
    # The gateway has the CAN fault block (docs/modbus.md "CAN fault block"): every 0 is refused
    # by the daemon as a bad value, whatever the plant makes of faults.
    rm = daemon.register_map
    assert rm.can_fault_units == (5,) and rm.can_fault_registers["kind"] == 8410
    assert rm.can_fault_kinds == KINDS
    with pytest.raises(ModbusError) as refused:
        daemon.modbus.write_registers(rm.can_fault_registers["every"], [0], 5)
    assert refused.value.code == 3  # illegal data value, not 2 (no such register)
    # docs/faults.md "CAN faults on cue": the gateway unplugged for 300 ms is shown in force with
    # the time left, and ends by itself.
    assert can0.faults == ()
    can0.fault("unplugged", for_ms=300)
    f = can0.timing().faults
    assert [(x.kind, x.node) for x in f] == [("unplugged", "gw:gw5")], f
    assert 0 < f[0].remaining_ms <= 300
    deadline = time.monotonic() + 5.0
    while can0.timing().faults:
        assert time.monotonic() < deadline, "the fault never ended: %s" % can0.timing().describe()
        time.sleep(0.02)


def test_an_ideal_bus_says_timing_and_faults_need_a_bit_rate(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    settled(daemon.gateway(5))
    can0 = daemon.bus("can0")
    with pytest.raises(NotTimed, match="ideal bus"):
        can0.timing()
    with pytest.raises(NotTimed, match="CAN fault block"):
        can0.fault("unplugged", for_ms=100)
