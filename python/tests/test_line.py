"""The line in time as the faces show it (docs/profibus.md "The line in time"): the measured bus
cycle in /api/v1/status, /metrics and candp2.Daemon.line; nothing of it on an ideal line."""

import json
import pathlib
import re
import urllib.request
from typing import Callable

import pytest

from candp2 import Daemon, Line, ModbusError, NoLine, WaitTimeout

from plants import MANUAL_514

Factory = Callable[..., Daemon]


def timed(baud: int) -> dict[str, object]:
    config: dict[str, object] = json.loads(json.dumps(MANUAL_514))
    master = config["master"]
    assert isinstance(master, dict)
    config["master"] = dict(master, baud=baud)
    return config


def test_the_measured_bus_cycle_is_seen_from_outside(candp2d: Factory) -> None:
    daemon = candp2d(timed(187500))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    # The start-up's rotation is no bus cycle (docs/daemon.md "Statistics of the steady line"):
    # wait for the first rotation of the steady line.
    line = daemon.line.wait_until(lambda li: li.bus_cycle_us is not None
                                  and li.bus_cycle_us.cycles > 0 and li)
    assert isinstance(line, Line) and line.baud == 187500
    c = line.bus_cycle_us
    assert c is not None
    # A rotation carries at least one Data_Exchange: SD2 request and answer at 187.5 kbit/s
    # take well over 1 ms of line time; the figures are ordered.
    assert 1000 < c.min <= c.mean <= c.max and c.min <= c.last <= c.max and c.cycles > 0
    assert daemon.http_url is not None
    with urllib.request.urlopen(daemon.http_url + "/metrics", timeout=5) as r:
        metrics = r.read().decode()
    got = dict(re.findall(r'^candp2_line_bus_cycle_seconds\{stat="(\w+)"\} (\S+)$', metrics,
                          re.M))
    assert set(got) == {"last", "min", "mean", "max"}, metrics[-2000:]
    assert float(got["max"]) >= float(got["min"]) > 0.001


def test_an_ideal_line_says_line_faults_need_a_baud_rate(candp2d: Factory) -> None:
    """A test written for a line in time, run on an ideal one, fails saying what is missing
    (master.baud), not with an AttributeError of None."""
    daemon = candp2d(MANUAL_514)
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    assert "line" not in daemon.http_status()
    assert daemon.has_line is False
    assert getattr(daemon, "line", None) is None  # NoLine is an AttributeError too
    with pytest.raises(NoLine, match=r"ideal line \(no master\.baud in the configuration\).*"
                                     r"line faults \(inject, noise\).*\"baud\": 1500000"):
        daemon.line.inject(5, "corrupt", count=3)


def test_line_faults_on_cue_show_in_the_counters(candp2d: Factory) -> None:
    """docs/faults.md "Line faults": three corrupted answers of station 5 are three illegal
    telegrams blamed on it; noise shows its remaining time."""
    daemon = candp2d(timed(1500000))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    line = daemon.line
    assert line is not None and line.live_list.ok == (5,)
    before = line.station(5)
    assert before.live == "ok" and before.fault is None
    line.inject(5, "corrupt", count=3)
    after = line.wait_until(lambda li: li.station(5).illegals >= before.illegals + 3
                            and li.station(5).fault is None and li)
    assert isinstance(after, Line)
    assert after.station(5).illegals == before.illegals + 3
    assert after.station(5).repeats > before.repeats
    line.noise(for_ms=3000)
    noisy = line.wait_until(lambda li: li.noise_remaining_ms)
    assert 0 < noisy <= 3000


def test_a_station_that_is_not_on_the_line_is_named_before_anything_is_written(
        candp2d: Factory) -> None:
    daemon = candp2d(timed(1500000))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    line = daemon.line
    assert line.configured == (5,)
    with pytest.raises(ValueError, match=r"^no station 99 on the line \(stations: 5\)$"):
        line.inject(99, "corrupt", count=3)
    with pytest.raises(ValueError, match=r"^no station 4 on the line \(stations: 5\)$"):
        line.inject(4, "silent")
    # Nothing was written: no fault anywhere, and the line goes on.
    assert all(s.fault is None for s in daemon.line.stations)


def test_waiting_for_a_line_counter(candp2d: Factory) -> None:
    """wait_until on the line and on one of its stations, like a gateway's: the counter's value
    when it holds; a timeout names the counter and its last value."""
    daemon = candp2d(timed(1500000))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    line = daemon.line
    station = line.station(5)
    line.inject(5, "corrupt", count=2, every=2)  # each answer repeated once: never lost
    illegals = station.wait_until(lambda s: s.illegals >= station.illegals + 2 and s.illegals)
    assert illegals == station.illegals + 2
    # Timeouts: what the predicate read, by name, with the value it last had; then the line.
    with pytest.raises(WaitTimeout) as e:
        line.wait_until(lambda li: li.station(5).illegals > 1000, timeout=0.3)
    text = str(e.value)
    assert text.startswith("line: lambda li: li.station(5).illegals > 1000: not true within "
                           "0.3 s; last saw station(5).illegals=%d (predicate returned False)"
                           % illegals), text
    assert "\nline: 1500000 bit/s, bus cycle " in text and "station 5 (ok): lost 0" in text
    with pytest.raises(WaitTimeout) as e:
        daemon.line.station(5).wait_until(lambda s: s.live == "missing" or s.lost > 0,
                                          timeout=0.3)
    text = str(e.value)
    assert text.startswith("line station 5: lambda s: s.live == \"missing\" or s.lost > 0: "
                           "not true within 0.3 s; last saw live='ok', lost=0"), text
    assert "\nstation 5 (ok): lost 0, syncs 1, repeats " in text, text


def test_the_line_described_for_a_failure_report(candp2d: Factory) -> None:
    """daemon.report() (the pytest plugin's section) shows the line: baud rate, bus cycle in the
    unit that reads, the live list, each station's counters in the table's order and its
    active fault."""
    daemon = candp2d(timed(9600))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch", timeout=10)
    # A fault that stays active: it spoils one answer in 65535 (the master repeats it).
    daemon.line.inject(5, "corrupt", count=65535, every=65535)
    daemon.line.station(5).wait_until(lambda s: s.fault)
    report = daemon.report()
    assert re.search(r"^line: 9600 bit/s, bus cycle \d+\.\d ms \(min \d+\.\d ms, mean "
                     r"[\d.]+ m?s, max [\d.]+ m?s over \d+ cycles\), \d+ retries, \d+ GAP polls$",
                     report, re.M), report
    assert "\n  live list: ok 5; missing none; phantom none\n" in report, report
    assert re.search(r"^  station 5 \(ok\): lost 0, syncs 1, repeats \d+, repeats_max \d+, "
                     r"illegals \d+, diagnostics \d+; fault corrupt \(\d+ left, every 65535\)$",
                     report, re.M), report


def test_an_ideal_line_in_the_report(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    assert "\nline: ideal (no master.baud: no line statistics)\n" in daemon.report()


def test_a_refused_line_fault_write_says_why_in_the_log(candp2d: Factory) -> None:
    """docs/daemon.md "Logging": a Modbus write the daemon refuses (here a line fault of kind 9,
    which does not exist) is logged once with its reason; repeats within a second are counted,
    not written."""
    daemon = candp2d(timed(1500000))
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    rm = daemon.register_map
    for _ in range(3):
        with pytest.raises(ModbusError, match=r"exception 0x03 \(illegal data value\)"):
            daemon.modbus.write_registers(rm.line_fault_registers["kind"], [9, 1, 1, 0], 5)
    daemon.gateway(5).wait_until(lambda g: "refused" in daemon.log)
    refused = [line for line in daemon.log.splitlines() if "refused" in line]
    assert len(refused) == 1, refused
    assert re.search(r"warning \[modbus\] 127\.0\.0\.1:\d+: unit 5: write \(function 16\) refused "
                     r"with exception 0x03 \(illegal data value\): line fault kind 9 \(0 none, 1 "
                     r"corrupt, 2 silent, 3 late, 4 double_address\)$", refused[0]), refused


def test_a_noise_burst_at_9600_is_followed_by_no_cascade(candp2d: Factory) -> None:
    """Live, as the replay scenario line-noise-9600 (docs/profibus.md "The line in time"): three
    gateways at 9.6 kbit/s whose watchdogs outlast the rotation that parameterizes them again.
    A 300 ms noise burst drops all three; each is parameterized again in one go, once, and no
    watchdog expires in the rotations after."""
    root = pathlib.Path(__file__).resolve().parents[2]
    config = json.loads((root / "config" / "line-9600-noise.json").read_text())
    daemon = candp2d(config)
    stations = (3, 4, 5)
    line = daemon.line
    line.wait_until(lambda li: all(li.station(a).live == "ok" for a in stations) and li,
                    timeout=10)
    line.noise(for_ms=300)
    back = line.wait_until(lambda li: all(li.station(a).syncs == 2 and li.station(a).live == "ok"
                                          for a in stations) and li, timeout=10)
    assert isinstance(back, Line) and back.bus_cycle_us is not None
    cycles = back.bus_cycle_us.cycles
    after = line.wait_until(lambda li: li.bus_cycle_us is not None
                            and li.bus_cycle_us.cycles >= cycles + 10 and li, timeout=10)
    assert isinstance(after, Line)
    for a in stations:
        s = after.station(a)
        assert (s.live, s.lost, s.syncs) == ("ok", 1, 2), after.describe()
    # The start-up and the rotations that parameterized the three again are no bus cycles.
    p = after.parameterization_cycle_us
    assert p is not None and after.bus_cycle_us is not None and p.cycles >= 2
    assert p.max > after.bus_cycle_us.max, after.describe()
