#!/usr/bin/python3
"""The front panel complete when it opens (docs/daemon.md "The page"): the page renders its view
from one event of the stream fetched before its load event (`/api/v1/events?once`), then follows
the stream. In Debian's headless chromium over the DevTools protocol (cdp.py), each view opened
by a navigation of its own: the time from the navigation's start to the page's `data-rendered`
mark (the view complete: every tile, the open panel with its slot rows or modules, the line view
when there is a line) stays under one second, and the view's data is in the DOM then:

  - the demo (config/demo.json, one gateway): `/` opens on gateway 3's panel;
  - config/plc-line.json: the overview (a gateway, two generic slaves) and slave 8's panel;
  - 122 gateways x 48 slots on a 12 Mbit/s line in time: the overview, gateway 17's panel, both
    with the line view's 122 station tiles;
  - `chromium --headless --dump-dom` of the demo's page holds gateway 3's slot rows (the dump is
    taken at the load event).

The measured times are printed. Bounded: every wait has a deadline; chromium is killed at the end.
"""

import os
import subprocess
import sys
import tempfile
import shutil

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import CHROMIUM_FLAGS, Browser  # noqa: E402
from http_common import ROOT, Daemon, demo_config, line_config  # noqa: E402

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
LIMIT_MS = 1000
ROWS = "document.querySelectorAll('#gw-%d .slots tbody tr[data-slot]').length"


def open_view(browser, url):
    """Navigates to `url` from a blank page; the page's data-rendered mark (ms since the
    navigation started)."""
    browser.call("Page.navigate", url="about:blank")
    browser.wait_for("a blank page", "location.href === 'about:blank'")
    browser.call("Page.navigate", url=url)
    return int(browser.wait_for("the view rendered (%s)" % url, "document.readyState === "
                                "'complete' && document.body.dataset.rendered", timeout=10))


def check_time(what, ms, times):
    times.append((what, ms))
    print("%s: complete %d ms after the navigation started" % (what, ms))
    assert ms <= LIMIT_MS, "%s complete only after %d ms" % (what, ms)


def test_views_complete_at_load(candp2_binary):
    times = []
    browser = Browser(CHROMIUM, width=1400, height=1000)
    try:
        browser.call("Page.enable")
        d = Daemon(candp2_binary, config=demo_config())
        try:
            d.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
            check_time("demo: gateway 3's panel", open_view(browser, d.base + "/"), times)
            assert browser.evaluate("location.hash") == "#gw=3"
            assert browser.evaluate(ROWS % 3) == 4
            # The load event comes after the first render: a DOM dump has the data.
            profile = tempfile.mkdtemp(prefix="candp2-chromium-")
            try:
                flags = [f for f in CHROMIUM_FLAGS if not f.startswith("--remote-debugging")]
                dom = subprocess.run([CHROMIUM] + flags + ["--user-data-dir=" + profile,
                                                           "--dump-dom", d.base + "/"],
                                     capture_output=True, text=True, timeout=60).stdout
            finally:
                shutil.rmtree(profile, ignore_errors=True)
            assert 'id="gw-3"' in dom and dom.count("<tr data-slot=") == 4, dom[:3000]
            assert "data-rendered=" in dom, dom[:3000]
        finally:
            d.stop()

        d = Daemon(candp2_binary, config=os.path.join(ROOT, "config", "plc-line.json"))
        try:
            d.wait_for("the slaves in Data_Exch",
                       lambda s: all(x["dp_state"] == "Data_Exch" for x in s["slaves"]))
            check_time("plc-line: the overview", open_view(browser, d.base + "/"), times)
            assert browser.evaluate("document.querySelectorAll('#tiles .tile').length") == 3
            check_time("plc-line: slave 8's panel", open_view(browser, d.base + "/#slave=8"),
                       times)
            assert browser.evaluate("document.querySelectorAll('#slave-8 tbody tr').length") > 0
        finally:
            d.stop()

        cfg = line_config(10)
        cfg["master"]["baud"] = 12000000
        d = Daemon(candp2_binary, config=cfg, timeout=60)
        try:
            d.wait_for("every gateway in Data_Exch",
                       lambda s: all(g["dp_state"] == "Data_Exch" for g in s["gateways"]),
                       timeout=60)
            n = len(cfg["gateways"])
            tiles = "document.querySelectorAll('#line .ltile').length"
            check_time("122 x 48: the overview and the line",
                       open_view(browser, d.base + "/"), times)
            assert browser.evaluate("document.querySelectorAll('#tiles .tile').length") == n
            assert browser.evaluate(tiles) == n
            check_time("122 x 48: gateway 17's panel and the line",
                       open_view(browser, d.base + "/#gw=17"), times)
            assert browser.evaluate(ROWS % 17) == 48
            assert browser.evaluate(tiles) == n
            assert browser.evaluate("+document.querySelector('#line canvas').dataset.points") >= 1
        finally:
            d.stop()
    finally:
        browser.close()
    print("times: " + ", ".join("%s %d ms" % t for t in times))
