"""The line in time as the faces show it (docs/profibus.md "The line in time"): the measured bus
cycle in /api/v1/status, /metrics and candp2.Daemon.line; nothing of it on an ideal line."""

import json
import re
import time
import urllib.request
from typing import Callable

from candp2 import Daemon, Line

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
    line = daemon.line
    assert line is not None and line.baud == 187500
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


def test_an_ideal_line_shows_none(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    daemon.gateway(5).wait_until(lambda g: g.state == "Data_Exch")
    assert daemon.line is None
    assert "line" not in daemon.http_status()


def line_until(daemon: Daemon, what: str, predicate: Callable[[Line], bool],
               timeout: float = 5.0) -> Line:
    """daemon.line, read again until predicate(line) holds (AssertionError after `timeout`)."""
    end = time.monotonic() + timeout
    while True:
        line = daemon.line
        assert line is not None
        if predicate(line):
            return line
        if time.monotonic() > end:
            raise AssertionError("%s not within %.0f s: %r" % (what, timeout, line))
        time.sleep(0.02)


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
    after = line_until(daemon, "three illegals of station 5",
                       lambda li: li.station(5).illegals >= before.illegals + 3
                       and li.station(5).fault is None)
    assert after.station(5).illegals == before.illegals + 3
    assert after.station(5).repeats > before.repeats
    line.noise(for_ms=3000)
    noisy = line_until(daemon, "noise on the line", lambda li: li.noise_remaining_ms > 0)
    assert noisy.noise_remaining_ms <= 3000
