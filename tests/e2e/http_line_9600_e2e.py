#!/usr/bin/python3
"""The line view of the front panel at 9.6 kbit/s (config/line-9600.json, docs/profibus.md "The
line in time"), in Debian's headless chromium over the DevTools protocol (cdp.py): the times read
at a glance and the counters come in the documented order.

  - the header's bus cycle in the unit that reads ("bus cycle 88.1 ms (max 1.17 s at 9.6
    kbit/s)"): milliseconds with one decimal below a second, seconds above, microseconds only
    below a millisecond; never a raw count of microseconds;
  - each station tile lists lost, syncs, repeats, repeats_max, illegals, diagnostics (the order
    of docs/profibus.md "Line statistics"), each with the status document's value;
  - the bus cycle plot's axis labels carry a unit, and its top follows the running cycle, not the
    start-up's longest rotation.

The screenshot of the page is kept as $CANDP2_TEST_OUTPUT/front-panel-line-9600.png. Bounded:
every wait has a deadline; chromium is killed at the end.
"""

import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import ROOT, STATION_COUNTERS, Daemon  # noqa: E402

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
TIME = r"(\d+ µs|\d+\.\d ms|\d+\.\d\d s)"
# The plot's axis labels as drawn (plot() in http/web/panel.js), recorded by a wrapped fillText.
RECORD_LABELS = """(() => { const c = document.querySelector('#line canvas');
  const g = c.getContext('2d'); window.labels = []; const f = g.fillText.bind(g);
  g.fillText = (t, x, y) => { window.labels.push(String(t)); f(t, x, y); }; return true; })()"""


def micros(text):
    """'912 µs', '252.4 ms', '1.17 s' in microseconds."""
    value, unit = text.split()
    return float(value) * {"µs": 1, "ms": 1e3, "s": 1e6}[unit]


def test_line_view_at_9600(candp2_binary, tmp_path):
    output_dir = os.environ.get("CANDP2_TEST_OUTPUT", str(tmp_path))
    os.makedirs(output_dir, exist_ok=True)
    with open(os.path.join(ROOT, "config", "line-9600.json")) as f:
        cfg = json.load(f)
    cfg["http"] = {"listen": "127.0.0.1:0"}
    d = Daemon(candp2_binary, config=cfg)
    browser = None
    try:
        # (Its gateways' 50 ms watchdog is shorter than the rotation: they drop out and are
        # parameterized again, the counters move.)
        s = d.wait_for("bus cycles measured", lambda s: s["line"]["bus_cycle_us"]["cycles"] > 10)
        assert s["line"]["baud"] == 9600, s["line"]
        browser = Browser(CHROMIUM, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("the view rendered", "document.body.dataset.rendered")
        header = browser.evaluate("document.getElementById('cycle').textContent")
        m = re.search(r"bus cycle %s \(max %s at 9\.6 kbit/s\)" % (TIME, TIME), header)
        assert m, header
        assert not re.search(r"\d{4,} µs", header), header
        assert micros(m.group(1)) <= micros(m.group(2)), header
        print("header: " + header)

        tiles = browser.evaluate("Array.from(document.querySelectorAll('#line .ltile'))"
                                 ".map(t => +t.id.slice(5))")
        assert tiles == [3, 5], tiles
        for a in tiles:
            shown = browser.evaluate("Array.from(document.querySelectorAll('#line-%d dt'))"
                                     ".map(d => d.textContent)" % a)
            assert shown == STATION_COUNTERS, (a, shown)
        st = next(x for x in d.status()["line"]["stations"] if x["address"] == 3)
        assert st["syncs"] >= 1, st
        browser.wait_for("station 3's syncs", "document.querySelector('#line-3 dd:nth-of-type(2)')"
                         ".textContent === '%d'" % st["syncs"])

        # The plot's next point: its labels have a unit; the axis' top (the first label) is the
        # longest running cycle plotted (last, min, mean), not the longest since the start.
        browser.evaluate(RECORD_LABELS)
        browser.wait_for("the plot drawn again", "window.labels.length >= 3", timeout=5)
        labels = browser.evaluate("window.labels")
        axis = labels[:3]
        assert all(re.fullmatch(TIME, t) for t in axis), labels
        running, longest = browser.evaluate(
            "[Math.max(...line.cycle.last, ...line.cycle.min, ...line.cycle.mean), "
            "Math.max(...line.cycle.max)]")
        assert abs(micros(axis[0]) - running) <= 0.01 * running + 1, (axis, running)
        print("plot axis: %s; running cycle up to %d µs, the longest since the start %d µs"
              % (", ".join(axis), running, longest))

        browser.keep_page(os.path.join(output_dir, "front-panel-line-9600.png"))
    finally:
        if browser:
            browser.close()
        d.stop()
