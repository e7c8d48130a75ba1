"""End-to-end: host stalls do not reach the simulated world (docs/daemon.md "Host stalls"; pytest,
ctest e2e_host_stall).

candp2d runs config/demo.json (gateway watchdog 200 ms, cycle 10 ms) and is stopped with SIGSTOP
three times for 300 ms. With the default master.host_stall_ms (50) the simulated world does not
see the stalls: no watchdog expiry, the gateway stays in Data_Exch and is parameterized once, and
the daemon counts 3 stalls of about 900 ms in all on GET /api/v1/status, /metrics, the Modbus
host block (docs/modbus.md "Host block"), the panel's event header and Daemon.host_stalls. With
master.host_stall_ms 0 (host lateness reaches the world, as before the simulated clock) the same
stalls expire the watchdog. Also on a line in time at 12 Mbit/s, where
the line's station counters stay at lost 0, syncs 1.
"""

import copy
import json
import os
import signal
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UNIT = 3
STALL_S = 0.3
STALLS = 3
EXPIRED = "watchdog expired"


def demo(baud=None, host_stall_ms=None):
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        config = json.load(f)
    config = copy.deepcopy(config)
    if baud is not None:
        config["master"]["baud"] = baud
    if host_stall_ms is not None:
        config["master"]["host_stall_ms"] = host_stall_ms
    return config


def await_true(predicate, timeout, what):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "not within %.0f s: %s" % (timeout, what)
        time.sleep(0.02)


def stall(daemon, seen):
    """SIGSTOP for STALL_S, SIGCONT; with `seen`, awaits the daemon's count of stalls moving."""
    before = daemon.host_stalls.count if seen else 0
    daemon.signal(signal.SIGSTOP)
    time.sleep(STALL_S)  # the stall itself
    daemon.signal(signal.SIGCONT)
    if seen:
        await_true(lambda: daemon.host_stalls.count > before, 5, "the stall counted")


def host_block(daemon):
    """The Modbus host block of the gateway's unit as {name: value} (32 bit each, high first)."""
    block = daemon.register_map.document["host"]
    words = daemon.modbus.read_registers("input_registers", block["first"], block["count"], UNIT)
    return {f["name"]: words[f["register"] - block["first"]] << 16
            | words[f["register"] - block["first"] + 1] for f in block["fields"]}


def event_header(daemon):
    """The panel's first event (GET /api/v1/events?once): its JSON."""
    body = daemon.http.get("/api/v1/events?once").decode()
    data = [line[len("data: "):] for line in body.splitlines() if line.startswith("data: ")]
    assert data, body[:200]
    return json.loads(data[0])


def metric(daemon, name):
    for line in daemon.http.get("/metrics").decode().splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise AssertionError("no %s in /metrics" % name)


@pytest.mark.parametrize("baud", [None, 12000000], ids=["ideal", "12M"])
def test_stalls_do_not_reach_the_world(candp2d, baud):
    daemon = candp2d(demo(baud))
    gw = daemon.gateway(UNIT)
    gw.wait_until(lambda g: g.state == "Data_Exch", timeout=10)
    assert daemon.host_stalls.count == 0
    assert set(host_block(daemon).values()) == {0}
    for _ in range(STALLS):
        stall(daemon, seen=True)
    # A watchdog of 200 ms would have expired within 200 ms of the last stall: await a cycle
    # well after that (the Data_Exchange counter moving past a second of cycles).
    start = gw.counters.data_exchanges
    gw.wait_until(lambda g: g.counters.data_exchanges >= start + 50, timeout=10)
    assert EXPIRED not in daemon.log
    assert gw.state == "Data_Exch"
    assert gw.counters.parameterizations == 1
    stalls = daemon.host_stalls
    # A loaded host may add stalls of its own; the three asked for are there, each about 300 ms.
    assert stalls.count >= STALLS
    assert 3 * 250 <= stalls.total_ms <= 3 * 250 + 600 * (stalls.count - STALLS) + 450
    assert 250 <= stalls.longest_ms
    assert stalls.total_ms == daemon.http_status()["host_stalls"]["total_ms"]
    assert metric(daemon, "candp2_host_stalls_total") == stalls.count
    assert metric(daemon, "candp2_host_stall_seconds_total") == pytest.approx(
        stalls.total_ms / 1000, abs=1e-6)
    assert metric(daemon, "candp2_host_stall_longest_seconds") == pytest.approx(
        stalls.longest_ms / 1000, abs=1e-6)
    regs = host_block(daemon)
    assert regs["host_stalls"] == stalls.count
    assert regs["host_stall_total_ms"] == int(stalls.total_ms)
    assert regs["host_stall_longest_ms"] == int(stalls.longest_ms)
    assert event_header(daemon)["host_stalls"]["count"] == stalls.count
    assert "host stall: the loop woke" in daemon.log
    assert "host stalls: %d, %.1f ms in all" % (stalls.count, stalls.total_ms) in daemon.report()
    if baud is not None:
        station = daemon.line.station(UNIT)
        assert (station.lost, station.syncs) == (0, 1), station.describe()


def test_stalls_reach_the_world_when_off(candp2d):
    daemon = candp2d(demo(host_stall_ms=0))
    gw = daemon.gateway(UNIT)
    gw.wait_until(lambda g: g.state == "Data_Exch", timeout=10)
    for _ in range(STALLS):
        stall(daemon, seen=False)
        if EXPIRED in daemon.log:
            break
        gw.wait_until(lambda g: g.state == "Data_Exch", timeout=10)
    await_true(lambda: EXPIRED in daemon.log, 5, "the watchdog expired")
    gw.wait_until(lambda g: g.counters.parameterizations >= 2, timeout=10)
    assert daemon.host_stalls.count == 0
