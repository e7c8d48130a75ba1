"""The line in time as the faces show it (docs/profibus.md "The line in time"): the measured bus
cycle in /api/v1/status, /metrics and candp2.Daemon.line; nothing of it on an ideal line."""

import json
import re
import urllib.request
from typing import Callable

from candp2 import Daemon

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
