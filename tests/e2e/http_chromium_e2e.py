#!/usr/bin/python3
"""The live front panel in headless Chromium: Debian's chromium loads the page from a
running candp2d (the demo configuration plus a gateway gw5 whose Chk_Cfg it rejects). With two
gateways the page opens on the overview: both tiles, gw5's marked faulty; a click on gateway 3's
tile opens its panel. After Modbus writes of Q 0..4 (enable axis1, read its speed every 100 ms,
30 % speed: the Unitek commands of config/demo.json) the panel must show the last written bytes in
gateway 3's slot table, LED D on (manual table 3.3.1: Data Exchange), the drive's replies in slot
I0, the frame in the trace; the deep link #gw=5 then shows gw5 with LED D off, LED E flashing
three times (waiting for Set_Prm after the Cfg fault) and the Cfg_Fault bit set — asserted on the
DOM through the DevTools protocol (cdp.py). A screenshot is kept
as $CANDP2_TEST_OUTPUT/front-panel.png (ctest: build/test-output/; else pytest's tmp_path).
Bounded: every wait has a deadline; chromium is killed at the end. pytest on the candp2 package
(ctest e2e_http_chromium); $CHROMIUM names the browser (default /usr/bin/chromium).
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import Daemon, demo_config  # noqa: E402

UNIT = 3
# Unitek REGID commands (REGID, value little-endian; Unitek manual examples 2, 10, 11).
COMMANDS = [[0x51, 0x00, 0x00, 0x00, 0x00],   # MODE = 0: enable
            [0x3D, 0x30, 0x64, 0x00, 0x00],   # read the actual speed 0x30 every 100 ms
            [0x31, 0x66, 0x26, 0x00, 0x00]]   # speed set point 9830 = 30 %

SLOT_BYTES = """(() => {
  const row = Array.from(document.querySelectorAll('#gw-3 .slots tbody tr'))
                   .find(r => r.cells[7].textContent === '%s');
  return row ? row.cells[8].textContent : null; })()"""
LED_D = """(() => { const l = document.getElementById('gw-3-led-D');
  return l && l.dataset.code === '1' && l.classList.contains('on'); })()"""
# gw5's LED E: code 3 and, within one 6 s sequence (its period), seen lit and dark (it flashes).
LED_E5 = """new Promise(done => {
  const l = document.getElementById('gw-5-led-E'); let lit = false, dark = false;
  const t = setInterval(() => {
    if (l.classList.contains('on')) lit = true; else dark = true;
    if (lit && dark) { clearInterval(t); done(l.dataset.code === '3'); } }, 20);
  setTimeout(() => { clearInterval(t); done(false); }, 6500); })"""


def write(d, gw, cmd):
    """Writes one 5-byte command to Q 0..4 (through the package) and waits until slot Q0 has
    sent it."""
    def q0(s):
        g = next(g for g in s["gateways"] if g["dp_address"] == UNIT)
        return next(x for x in g["slots"] if x["plc"] == "Q0")
    before = q0(d.status())["frames"]
    gw.outputs[0:5] = bytes(cmd)
    d.wait_for("command %02X sent" % cmd[0], lambda s: q0(s)["frames"] > before)


def test_front_panel(candp2_binary, tmp_path):
    output_dir = os.environ.get("CANDP2_TEST_OUTPUT", str(tmp_path))
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    os.makedirs(output_dir, exist_ok=True)
    cfg = demo_config()
    # docs/slots.md "Chk_Cfg slots": Page-Mode on with a plain slot is rejected (Cfg code 9).
    # A long name must stay in the panel's left column and in its tile.
    cfg["gateways"].append({"name": "gw5-hall2-line7-station5-dp2can", "address": 5, "bus": "can0",
                            "parameters": {"can_bitrate": "500k", "page_mode": True},
                            "slots": [{"io": "output", "address": 32, "length": 2,
                                       "comment": "03,05,00"}]})
    d = Daemon(candp2_binary, config=cfg)
    browser = None
    try:
        d.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        browser = Browser(chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("the overview's two tiles, gw5 faulty",
                         "document.querySelectorAll('#tiles .tile').length === 2 && "
                         "document.getElementById('tile-5').classList.contains('faulty')")
        # An ideal line: no line view (it polled the status once and found no "line").
        assert browser.evaluate("document.getElementById('line').hidden") is True
        browser.evaluate("document.getElementById('tile-3').click()")
        browser.wait_for("gateway 3's panel", "!!document.getElementById('gw-3')")
        assert browser.evaluate("location.hash") == "#gw=3"
        assert browser.evaluate("document.getElementById('overview').hidden") is True
        before = browser.wait_for("slot Q0", SLOT_BYTES % "Q0")
        want = " ".join("%02X" % b for b in COMMANDS[-1])
        assert before != want, before
        # What the page knew when the panel opened: the tile's frames/s, at once, no placeholder;
        # no NMT state for a gateway with CANopen off (docs/canopen.md).
        assert int(browser.evaluate("document.querySelector('#gw-3 canvas').dataset.points")) >= 1
        rates = browser.evaluate("Array.from(document.querySelectorAll('#gw-3 .busplot dt'))"
                                 ".find(d => d.textContent === 'rx/s, tx/s')"
                                 ".nextElementSibling.textContent")
        assert rates.replace(", ", "").isdigit(), rates
        nmt = browser.evaluate("Array.from(document.querySelectorAll('#gw-3 .plate dt'))"
                               ".find(d => d.textContent === 'NMT').nextElementSibling.textContent")
        assert nmt == "— (CANopen off)", nmt

        gw = d.gateway(UNIT)
        for cmd in COMMANDS:
            write(d, gw, cmd)

        browser.wait_for("the written bytes %s in slot Q0" % want,
                         "(%s) === '%s'" % (SLOT_BYTES % "Q0", want))
        browser.wait_for("LED D on", LED_D)
        # The drive's answers arrive on 0x181 (slot I0) and the trace shows the command frame.
        browser.wait_for("the drive's reply in slot I0", "(%s || '').startsWith('30 ')"
                         % (SLOT_BYTES % "I0"))
        browser.wait_for("frame 0x201 with the command in the trace",
                         "Array.from(document.querySelectorAll('#bus-can0 .trace tr'))"
                         ".some(r => r.cells[1].textContent === '0x201' && "
                         "r.cells[3].textContent === '%s')" % want)
        state = browser.evaluate("document.querySelector('#gw-3 .kv dd').textContent")
        assert state == "Data_Exch", state
        browser.wait_for("axis1 turning", "(() => { const dd = document.querySelectorAll("
                         "'#drive-axis1 dd'); return dd.length > 3 && +dd[3].textContent > 0; })()")
        # Let the frames/s plot collect three one-second points, then keep the picture.
        browser.wait_for("a frames/s plot", "(() => { const p = document.querySelector("
                         "'#gw-3 canvas'); return p && +p.dataset.points >= 3; })()", timeout=15)
        path = os.path.join(output_dir, "front-panel.png")
        browser.screenshot_page(path)
        assert os.path.getsize(path) > 10000, os.path.getsize(path)
        print("screenshot: " + path)
        # The deep link to gw5: its panel replaces gateway 3's.
        browser.evaluate("location.hash = '#gw=5'")
        browser.wait_for("gw5's panel alone", "!!document.getElementById('gw-5') && "
                         "!document.getElementById('gw-3')")
        # gw5: rejected Chk_Cfg → LED D off, LED E 3 flashes, Cfg_Fault bit (diagnosis byte 0).
        browser.wait_for("gw5's LED D off", "document.getElementById('gw-5-led-D')"
                         ".dataset.code === '0'")
        r = browser.call("Runtime.evaluate", expression=LED_E5, awaitPromise=True,
                         returnByValue=True)
        assert r["result"].get("value") is True, r
        browser.wait_for("gw5's Cfg_Fault bit",
                         "Array.from(document.querySelectorAll('#gw-5 .bit.set'))"
                         ".some(b => b.textContent === 'Cfg_Fault')")
        # Its long name wraps inside the front plate; the plate keeps its column.
        wide = browser.evaluate("(() => { const p = document.querySelector('#gw-5 .plate');"
                                " return p.scrollWidth - p.clientWidth; })()")
        assert wide <= 1, wide
    finally:
        if browser:
            browser.close()
        d.stop()
