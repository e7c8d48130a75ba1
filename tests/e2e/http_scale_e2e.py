"""The live front panel at the largest line the product allows: 122 gateways x 48
six-byte slots (http_common.line_config, master cycle 10 ms) in Debian's headless chromium over the
DevTools protocol (cdp.py), pytest on the candp2 package (ctest e2e_http_scale):

  - the overview (one tile per gateway) is drawn within 2 s of the page's load, no tile's text
    overflows it (gateway names of 32 characters, the longest allowed), and a screenshot is kept
    ($CANDP2_TEST_OUTPUT/overview-122.png);
  - a click on gateway 17's tile opens its panel with its 48 slot rows (#gw=17);
  - a Modbus write of gateway 17's first output slot shows on that open panel;
  - the demo (one gateway) opens on its panel, with no overview to go back to.

Bounded: every wait has a deadline; chromium is killed at the end. $CHROMIUM names the browser.
"""

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import (LINE_GATEWAYS, LINE_SLOTS, SLOT_LEN, Daemon,  # noqa: E402
                         line_config, line_slot_address)

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
GW = 17
ROWS = "#gw-%d .slots tbody tr" % GW
ROW_BYTES = """(() => {
  const row = Array.from(document.querySelectorAll('%s'))
                   .find(r => r.cells[7].textContent === '%%s');
  return row ? row.cells[8].textContent : null; })()""" % ROWS


# The elements (by id or class) whose content is wider than their box.
OVERFLOWING = """Array.from(document.querySelectorAll('%s'))
  .filter(e => e.scrollWidth > e.clientWidth + 1).map(e => e.id || e.className)"""


def test_overview_then_one_gateway_at_122_x_48(candp2_binary):
    config = line_config(10)
    for g in config["gateways"]:  # the longest names, as a plant's naming scheme makes them
        g["name"] = ("hall2-line7-station-%d-dp2can" % g["address"]).ljust(32, "x")
    d = Daemon(candp2_binary, config=config, timeout=60)
    browser = None
    try:
        d.wait_for("every gateway in Data_Exch",
                   lambda s: all(g["dp_state"] == "Data_Exch" for g in s["gateways"]), timeout=60)
        browser = Browser(CHROMIUM, width=1400, height=1000)
        browser.call("Page.enable")
        t0 = time.monotonic()
        browser.call("Page.navigate", url=d.base + "/")
        drawn = browser.wait_for("the overview drawn", "document.body.dataset.drawn", timeout=10)
        waited = time.monotonic() - t0
        tiles = browser.evaluate("document.querySelectorAll('#tiles .tile').length")
        assert tiles == LINE_GATEWAYS, tiles
        # performance.now() at the first paint with every tile: ms since the navigation started.
        assert int(drawn) <= 2000, drawn
        print("overview of %d gateways drawn %s ms after the navigation started (%.2f s here)"
              % (tiles, drawn, waited))
        state = browser.evaluate("document.querySelector('#tile-%d .tstate').textContent" % GW)
        assert state == "Data_Exch", state
        # Every tile keeps its text inside (the name is cut with an ellipsis).
        over = browser.evaluate(OVERFLOWING % "#tiles .tile, #tiles .thead")
        assert over == [], over
        output_dir = os.environ.get("CANDP2_TEST_OUTPUT", "/tmp")
        os.makedirs(output_dir, exist_ok=True)
        path = os.path.join(output_dir, "overview-122.png")
        browser.screenshot(path)
        assert os.path.getsize(path) > 10000, os.path.getsize(path)
        print("screenshot: " + path)

        browser.evaluate("document.getElementById('tile-%d').click()" % GW)
        browser.wait_for("gateway %d's %d slot rows" % (GW, 2 * LINE_SLOTS),
                         "document.querySelectorAll('%s').length === %d" % (ROWS, 2 * LINE_SLOTS))
        assert browser.evaluate("location.hash") == "#gw=%d" % GW
        assert browser.evaluate("document.getElementById('overview').hidden") is True

        address = line_slot_address(GW, 0)
        data = bytes([0xC0, 0xFF, 0xEE, GW, 0x12, 0x34])
        assert len(data) == SLOT_LEN
        want = " ".join("%02X" % b for b in data)
        before = browser.wait_for("slot Q%d" % address, ROW_BYTES % ("Q%d" % address))
        assert before != want, before
        t = time.monotonic()
        d.gateway(GW).outputs[address:address + SLOT_LEN] = data
        browser.wait_for("the written bytes in slot Q%d" % address,
                         "(%s) === '%s'" % (ROW_BYTES % ("Q%d" % address), want), timeout=5)
        print("Modbus write to gateway %d shown on its panel after %.2f s"
              % (GW, time.monotonic() - t))
    finally:
        if browser:
            browser.close()
        d.stop()


def test_the_demo_opens_on_its_panel(candp2_binary):
    d = Daemon(candp2_binary)
    browser = None
    try:
        browser = Browser(CHROMIUM, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("gateway 3's panel", "!!document.querySelector('#gw-3 .slots tbody tr')")
        assert browser.evaluate("location.hash") == "#gw=3"
        assert browser.evaluate("document.getElementById('overview').hidden") is True
        assert browser.evaluate("document.getElementById('back').hidden") is True
    finally:
        if browser:
            browser.close()
        d.stop()
