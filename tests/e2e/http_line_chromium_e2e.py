#!/usr/bin/python3
"""The PROFIBUS line on the front panel in headless Chromium (docs/daemon.md "HTTP face",
docs/profibus.md "Line statistics"): config/demo.json on a line in time (master.baud). The page
shows the line of the stream's header below the panel: one tile per station of the status
document's line (its address, live state and counters, under the document's names, in the
table's order: STATION_COUNTERS) and the bus cycle plot (last, min, mean, max), one point a
second. On an ideal line there is none of it
(http_chromium_e2e.py). A screenshot is kept as $CANDP2_TEST_OUTPUT/front-panel-line.png.
Bounded: every wait has a deadline; chromium is killed at the end.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import STATION_COUNTERS, Daemon, demo_config  # noqa: E402

UNIT = 3


def addresses(line):
    """The addresses the page shows a tile for: the stations, else the live list's."""
    if "stations" in line:
        return sorted(s["address"] for s in line["stations"])
    return sorted(a for v in line.get("live_list", {}).values() for a in v)


def test_line_view(candp2_binary, tmp_path):
    output_dir = os.environ.get("CANDP2_TEST_OUTPUT", str(tmp_path))
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    os.makedirs(output_dir, exist_ok=True)
    cfg = demo_config()
    cfg["master"] = dict(cfg.get("master", {}), baud=1500000)
    d = Daemon(candp2_binary, config=cfg)
    browser = None
    try:
        s = d.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        assert "line" in s, sorted(s)
        browser = Browser(chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("the line view", "document.getElementById('line').hidden === false")
        title = browser.evaluate("document.querySelector('#line h2').textContent")
        assert title == "PROFIBUS line", title
        # The bus cycle plot: a point a second from the stream.
        browser.wait_for("three points of the bus cycle", "(() => { const c = document."
                         "querySelector('#line canvas'); return c && +c.dataset.points >= 3; })()",
                         timeout=15)
        header = browser.evaluate("document.getElementById('cycle').textContent")
        assert "bus cycle" in header and "1500 kbit/s" in header, header
        # A tile for each station the document lists, in address order.
        want = addresses(d.status()["line"])
        browser.wait_for("%d station tile(s)" % len(want),
                         "JSON.stringify(Array.from(document.querySelectorAll('#line .ltile'))"
                         ".map(t => +t.id.slice(5))) === '%s'" % str(want).replace(" ", ""))
        line = d.status()["line"]
        if "stations" in line:
            st = next(s for s in line["stations"] if s["address"] == UNIT)
            names = [k for k, v in st.items() if k != "address" and isinstance(v, int)]
            assert sorted(names) == sorted(STATION_COUNTERS), names
            browser.wait_for("station %d ok" % UNIT, "document.getElementById('line-%d')"
                             ".classList.contains('live-ok')" % UNIT)
            shown = browser.evaluate("Array.from(document.querySelectorAll('#line-%d dt'))"
                                     ".map(d => d.textContent)" % UNIT)
            assert shown == STATION_COUNTERS, shown
        browser.keep_page(os.path.join(output_dir, "front-panel-line.png"))
    finally:
        if browser:
            browser.close()
        d.stop()
