#!/usr/bin/python3
"""Generic DP-V0 slaves on the live front panel and in the HTTP API (docs/slaves.md "Front panel
and HTTP API"), in Debian's headless chromium over the DevTools protocol (cdp.py), on
config/plc-line.json as candp2 ships it (the Daemon moves its listeners to free ports): gateway
gw3 and the generic slaves io1 (DP address 8: 8 DI, 8 DO, 2 AI, field side on unit 108) and io2
(address 9). With generic slaves beside its one gateway the page opens on the overview: three
tiles, the slaves' with their model and DP state and no LEDs. A click on io1's tile opens its
panel (#slave=8) with its three modules; a Modbus write of io1's PLC outputs (unit 8, Q 100)
shows in the "8 DO" module's output bytes, a field-side write (unit 108, holding registers) in
the "8 DI" and "2 AI" modules' input bytes, a diagnosis alarm in the Ext_Diag bytes; a forced Prm
fault of io2 (its slave fault registers, docs/faults.md "Generic slaves") shows on its tile. The
status JSON and /metrics carry the slaves too. A screenshot of the slave panel is kept as
$CANDP2_TEST_OUTPUT/slave-panel.png. Bounded: every wait has a deadline; chromium is killed at
the end. pytest on the candp2 package (ctest e2e_http_slaves); $CHROMIUM names the browser.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import ROOT, Daemon  # noqa: E402

PLC_LINE = os.path.join(ROOT, "config", "plc-line.json")

# The text of one cell of a module row of io1's panel (9 = outputs, 10 = inputs, 1-based like
# the columns: slot, module, Cfg, in, out, in at, out at, PLC, outputs, inputs).
MODULE_CELL = """(() => {
  const row = Array.from(document.querySelectorAll('#slave-8 .modules tbody tr'))
                   .find(r => r.dataset.module === '%s');
  return row ? row.cells[%d].textContent : null; })()"""
OUT, IN = 8, 9


def cell(module, column, want):
    return "(%s) === '%s'" % (MODULE_CELL % (module, column), want)


def test_generic_slaves_on_the_front_panel(candp2_binary, tmp_path):
    output_dir = os.environ.get("CANDP2_TEST_OUTPUT", str(tmp_path))
    chromium = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    os.makedirs(output_dir, exist_ok=True)
    d = Daemon(candp2_binary, config=PLC_LINE)
    browser = None
    try:
        s = d.wait_for("both slaves in Data_Exch", lambda s: len(s["slaves"]) == 2 and all(
            x["dp_state"] == "Data_Exch" and x["master"]["state"] == "Data_Exch"
            for x in s["slaves"]))
        io1_json = next(x for x in s["slaves"] if x["name"] == "io1")
        assert [m["name"] for m in io1_json["modules"]] == ["8 DI", "8 DO", "2 AI"], io1_json
        assert io1_json["field_unit"] == 108 and io1_json["kind"] == "in-process", io1_json
        model = io1_json["gsd"]["model"]
        assert model, io1_json

        browser = Browser(chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("the overview's three tiles, two of them slaves",
                         "document.querySelectorAll('#tiles .tile').length === 3 && "
                         "document.querySelectorAll('#tiles .tile.slave').length === 2")
        assert browser.evaluate("location.hash") == "", "opened a panel instead of the overview"
        browser.wait_for("io1's tile with its model and Data_Exch",
                         "(() => { const t = document.getElementById('tile-8'); return t && "
                         "t.textContent.includes('%s') && t.textContent.includes('Data_Exch') "
                         "&& !t.querySelector('.led'); })()" % model)

        browser.evaluate("document.getElementById('tile-8').click()")
        browser.wait_for("io1's panel", "!!document.getElementById('slave-8')")
        assert browser.evaluate("location.hash") == "#slave=8"
        assert browser.evaluate("document.getElementById('overview').hidden") is True
        browser.wait_for("io1's three modules",
                         "document.querySelectorAll('#slave-8 .modules tbody tr').length === 3")

        io1, io2 = d.slave("io1"), d.slave("io2")
        # The PLC's outputs (unit 8, Q 100: the 8 DO module) reach the panel's output bytes.
        before = browser.evaluate(MODULE_CELL % ("8 DO", OUT))
        assert before != "A5", before
        io1.outputs[100] = 0xA5
        browser.wait_for("A5 in the 8 DO module's outputs", cell("8 DO", OUT, "A5"))
        # The sensors' inputs (unit 108, holding registers): 8 DI, then 2 AI.
        io1.field_inputs[0:5] = bytes.fromhex("3C 12 34 56 78")
        browser.wait_for("3C in the 8 DI module's inputs", cell("8 DI", IN, "3C"))
        browser.wait_for("the 2 AI module's inputs", cell("2 AI", IN, "12 34 56 78"))
        # A diagnosis alarm: the Ext_Diag bit and the device-related block in Ext_Diag_Data.
        io1.alarm(b"\x01\x02")
        browser.wait_for("the alarm's Ext_Diag_Data",
                         "document.querySelector('#slave-8 .ext').textContent === '03 01 02'")
        browser.wait_for("the Ext_Diag bit", "Array.from(document.querySelectorAll("
                         "'#slave-8 .bit.set')).some(b => b.textContent === 'Ext_Diag')")
        path = os.path.join(output_dir, "slave-panel.png")
        browser.screenshot(path)
        assert os.path.getsize(path) > 10000, os.path.getsize(path)
        print("screenshot: " + path)

        # A forced Prm fault of io2 shows on its tile in the overview, io1's alarm on its own.
        io2.force_prm_fault()
        browser.evaluate("document.getElementById('back').click()")
        browser.wait_for("the overview", "location.hash === '' || location.hash === '#'")
        browser.wait_for("io2's tile faulty with its Prm fault",
                         "(() => { const t = document.getElementById('tile-9'); return t && "
                         "t.classList.contains('faulty') && "
                         "t.querySelector('.tfault').textContent === 'Prm fault (forced)'; })()")
        browser.wait_for("io1's tile with its diagnosis alarm",
                         "document.querySelector('#tile-8 .tfault').textContent === "
                         "'diagnosis alarm'")
        io2.force_prm_fault(False)
        io1.clear_alarm()
        browser.wait_for("io2 back in Data_Exch, its fault line empty",
                         "(() => { const t = document.getElementById('tile-9'); return "
                         "t.querySelector('.tfault').textContent === '' && "
                         "t.querySelector('.tstate').textContent === 'Data_Exch'; })()")

        code, _, body = d.get("/metrics")
        assert code == 200
        text = body.decode()
        assert 'candp2_slave_dp_state{address="8",name="io1"} 2\n' in text, text[-2000:]
        assert 'candp2_slave_data_exchanges_total{address="9",name="io2"} ' in text
    finally:
        if browser:
            browser.close()
        d.stop()
