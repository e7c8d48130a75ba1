#!/usr/bin/python3
"""A CAN bus in time on the front panel in headless Chromium (docs/can-bus.md "Seen from
outside", docs/daemon.md "HTTP face"): config/demo.json with its bus can0 at 500 kbit/s, axis1
asked for its speed every 100 ms (so that the bus's figures change all the time). The
gateway's panel shows under its bus the exact load, a point a second, and a table of the bus's
identifiers (frames, period, jitter, queueing latency last/mean/max) from the stream, the rows
those of the status document's `identifiers`; its error frames and a table of its nodes (name,
TEC, REC, state), the rows those of the status document's `nodes`; a CAN fault on cue in force
as text under the bus (kind, node, the time left), gone after none. On an ideal bus none of it
shows (http_chromium_e2e.py's demo). A screenshot is kept as
$CANDP2_TEST_OUTPUT/front-panel-bus.png.
Bounded: every wait has a deadline; chromium is killed at the end.
"""

import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import Daemon, demo_config  # noqa: E402

ROWS = "Array.from(document.querySelectorAll('#bus-can0 .ids tbody tr'))"
NODES = "Array.from(document.querySelectorAll('#bus-can0 .nodes tbody tr'))"


def test_bus_view(candp2_binary, tmp_path):
    output_dir = os.environ.get("CANDP2_TEST_OUTPUT", str(tmp_path))
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    os.makedirs(output_dir, exist_ok=True)
    cfg = demo_config()
    cfg["buses"]["can0"]["bitrate"] = "500k"
    d = Daemon(candp2_binary, config=cfg)
    browser = None
    try:
        d.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        # Unitek REGID 0x3D: axis1 sends its actual speed (0x30) every 100 ms on 0x181.
        d.gateway(3).outputs[0:5] = bytes([0x3D, 0x30, 0x64, 0x00, 0x00])
        s = d.wait_for("axis1's replies on the bus in time", lambda s: any(
            i["id"] == 0x181 and i["frames"] >= 2 for i in s["buses"][0].get("identifiers", [])))
        bus = s["buses"][0]
        assert bus["timed_bitrate"] == 500000, bus
        browser = Browser(chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/#gw=3")
        browser.wait_for("the bus in time's view",
                         "(() => { const t = document.querySelector('#bus-can0 .timed');"
                         " return !!t && !t.hidden; })()")
        # One row per identifier of the status document, in its order (of priority).
        want = [("0x%03X" % i["id"]) + (" R" if i["rtr"] else "")
                for i in d.status()["buses"][0]["identifiers"]]
        browser.wait_for("the identifiers %s" % want,
                         "JSON.stringify(%s.map(r => r.cells[0].textContent)) === '%s'"
                         % (ROWS, json.dumps(want, separators=(",", ":"))),
                         timeout=10)
        cells = browser.evaluate("%s[0].cells.length" % ROWS)
        assert cells == 7, cells  # identifier, frames, period, jitter, latency last/mean/max
        frames = int(browser.evaluate("%s[0].cells[1].textContent" % ROWS))
        assert frames >= 1, frames
        # The exact load: a point a second.
        browser.wait_for("two points of the load plot",
                         "+document.querySelector('#bus-can0 .timed canvas').dataset.points >= 2",
                         timeout=15)
        info = browser.evaluate("document.querySelector('#bus-can0 .kv').textContent")
        assert "max load" in info and "lost" in info, info
        # docs/can-bus.md "Error confinement": everyone acknowledges, no error frame; one row
        # per node of the status document, in its order: name, TEC, REC, state.
        assert "error frames0" in info, info
        nodes = [[n["name"], str(n["tec"]), str(n["rec"]), n["state"]]
                 for n in d.status()["buses"][0]["nodes"]]
        assert any(n[0].startswith("gw:") for n in nodes), nodes
        browser.wait_for("the nodes %s" % nodes,
                         "JSON.stringify(%s.map(r => Array.from(r.cells).map(c => c.textContent)))"
                         " === '%s'" % (NODES, json.dumps(nodes, separators=(",", ":"))),
                         timeout=10)
        # The CAN faults on cue in force, as the line shows a station's fault: the gateway
        # unplugged for a minute (the time left, from the status document), then none.
        fault = "document.querySelector('#bus-can0 .bfault')"
        assert browser.evaluate("%s.hidden" % fault), "a fault shown before any"
        d.bus("can0").fault("unplugged", for_ms=60000, gateway=3)
        f = d.wait_for("the fault in force", lambda s: s["buses"][0]["faults"])["buses"][0]
        assert f["faults"][0]["kind"] == "unplugged" and f["faults"][0]["remaining_ms"] > 50000, f
        text = browser.wait_for("the fault on the panel",
                                "(() => { const f = %s; return !f.hidden && f.textContent; })()"
                                % fault, timeout=10)
        assert text.startswith("unplugged " + f["faults"][0]["node"] + " ") and \
            text.endswith(" ms"), text
        browser.keep_page(os.path.join(output_dir, "front-panel-bus.png"))
        d.bus("can0").fault("none", gateway=3)
        browser.wait_for("no fault on the panel", "%s.hidden" % fault, timeout=10)
    finally:
        if browser:
            browser.close()
        d.stop()
