#!/usr/bin/python3
"""The live front panel in headless Chromium (issue 13): Debian's chromium loads the page from a
running candp2d (demo configuration); after a Modbus write of Q 0..4 the page must show the new
bytes in gateway 3's slot table and LED D on (manual table 3.3.1: Data Exchange), asserted on the
DOM through the DevTools protocol (cdp.py). A screenshot is kept as
<output-dir>/front-panel.png. Bounded: every wait has a deadline; chromium is killed at the end.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import Daemon  # noqa: E402

from pymodbus.client import ModbusTcpClient  # python3-pymodbus

UNIT = 3
COMMAND = [0x3D, 0x30, 0x00, 0x00, 0x00]  # Unitek: read the actual speed once (example 10)

SLOT_BYTES = """(() => {
  const row = Array.from(document.querySelectorAll('#gw-3 .slots tbody tr'))
                   .find(r => r.cells[7].textContent === '%s');
  return row ? row.cells[8].textContent : null; })()"""
LED_D = """(() => { const l = document.getElementById('gw-3-led-D');
  return l && l.dataset.code === '1' && l.classList.contains('on'); })()"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--output-dir", required=True)
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    args = ap.parse_args()
    os.makedirs(args.output_dir, exist_ok=True)
    d = Daemon(args.candp2d)
    browser = None
    try:
        d.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        browser = Browser(args.chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("gateway 3's panel", "!!document.getElementById('gw-3')")
        before = browser.wait_for("slot Q0", SLOT_BYTES % "Q0")
        want = " ".join("%02X" % b for b in COMMAND)
        assert before != want, before

        mb = ModbusTcpClient("127.0.0.1", port=d.modbus_port, timeout=3)
        assert mb.connect()
        rr = mb.write_registers(0, [(COMMAND[0] << 8) | COMMAND[1],
                                    (COMMAND[2] << 8) | COMMAND[3], COMMAND[4] << 8], slave=UNIT)
        assert not rr.isError(), rr
        mb.close()

        browser.wait_for("the written bytes %s in slot Q0" % want,
                         "(%s) === '%s'" % (SLOT_BYTES % "Q0", want))
        browser.wait_for("LED D on", LED_D)
        # The drive's answer arrives on 0x181 (slot I0) and the trace shows the command frame.
        browser.wait_for("the drive's reply in slot I0", "(%s || '').startsWith('30 ')"
                         % (SLOT_BYTES % "I0"))
        browser.wait_for("frame 0x201 in the trace",
                         "Array.from(document.querySelectorAll('#bus-can0 .trace td'))"
                         ".some(td => td.textContent === '0x201')")
        state = browser.evaluate("document.querySelector('#gw-3 .kv dd').textContent")
        assert state == "Data_Exch", state
        # Let the frames/s plot collect three one-second points, then keep the picture.
        browser.wait_for("a frames/s plot", "(() => { const p = document.querySelector("
                         "'#gw-3 canvas'); return p && +p.dataset.points >= 3; })()", timeout=15)
        path = os.path.join(args.output_dir, "front-panel.png")
        browser.call("Emulation.setDeviceMetricsOverride", width=1400, height=1000,
                     deviceScaleFactor=1, mobile=False)
        browser.screenshot(path)
        assert os.path.getsize(path) > 10000, os.path.getsize(path)
        print("screenshot: " + path)
    finally:
        if browser:
            browser.close()
        d.stop()
    print("PASS")


if __name__ == "__main__":
    main()
