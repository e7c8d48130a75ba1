"""A line of generic DP-V0 slaves alone, no gateway and no CAN bus (docs/slaves.md "A line of
generic slaves alone"), end to end: candp2d checks config/slaves-line.json, prints its Modbus map
(text and JSON: units 0 and 255 on the first slave), starts on it (the Daemon moves its listeners
to free ports, a pcapng capture is added) and its faces answer outside clients: mbpoll writes the
PLC outputs of slave in1 (unit 4) and reads them back on its field side (unit 104), writes in2's
field inputs (unit 105) and reads them in the PLC image through unit 0; /api/v1/status has both
slaves in Data_Exch and no gateway or bus, the first SSE event their tiles, /metrics their DP
state, the page is served; the capture holds the DP telegrams. In Debian's headless chromium
(cdp.py; $CHROMIUM names it) the page opens on the overview: two slave tiles, no gateway count;
a click opens in1's panel with its module. Both wire roles (docs/profibus.md)
without a gateway: a candp2d in role "slaves" serves the two slaves on a pty, a second one in role
"master" drives them there as remote stations, and the PLC image goes both ways. pytest on the
candp2 package (ctest e2e_slaves_line).
"""

import json
import os
import re
import socket
import struct
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp import Browser  # noqa: E402
from http_common import ROOT, Daemon  # noqa: E402

import candp2  # noqa: E402  (http_common put python/ on the path)

CONFIG = os.path.join(ROOT, "config", "slaves-line.json")
MBPOLL = "/usr/bin/mbpoll"
WAIT = 10.0


def run(*argv):
    r = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=WAIT)
    return r.returncode, r.stdout + r.stderr


def mbpoll(daemon, unit, table, address, *values, count=1):
    """One mbpoll request (TCP, PDU addressing, hex); the registers read as {address: value}."""
    args = [MBPOLL, "-m", "tcp", "-p", daemon.modbus_port, "-0", "-1", "-o", "2", "-a", unit,
            "-t", "%d:hex" % table, "-r", address]
    if not values:
        args += ["-c", count]
    rc, out = run(*args, "127.0.0.1", *values)
    assert rc == 0, out
    return {int(a): int(v, 16) for a, v in re.findall(r"\[(\d+)\]:\s+0x([0-9A-Fa-f]+)", out)}


def packets(path):
    """The Enhanced Packet Blocks of a pcapng file (block type 6), counted."""
    n = 0
    with open(path, "rb") as f:
        data = f.read()
    at = 0
    while at + 12 <= len(data):
        kind, length = struct.unpack_from("<II", data, at)
        assert length >= 12 and length % 4 == 0, (at, length)
        n += kind == 6
        at += length
    assert at == len(data), "a truncated block at %d" % at
    return n


def first_event(port, query):
    """The first `event: status` of /api/v1/events?QUERY, its data parsed (HTTP/1.0: no
    chunked encoding between the bytes)."""
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT) as s:
        s.sendall(b"GET /api/v1/events?%s HTTP/1.0\r\nHost: x\r\n\r\n" % query.encode())
        data = b""
        while True:
            m = re.search(rb"event: status\r?\ndata: (.*?)\r?\n\r?\n", data, re.S)
            if m:
                return json.loads(m.group(1))
            chunk = s.recv(1 << 16)
            assert chunk, data[-500:]
            data += chunk


def test_check_and_the_map_without_a_gateway(candp2_binary):
    rc, out = run(candp2_binary, "--config", CONFIG, "--check")
    assert rc == 0, out
    assert "configuration OK (0 gateway(s), 2 generic slave(s), 0 bus(es), 0 warning(s))" in out
    rc, text = run(candp2_binary, "--config", CONFIG, "--print-modbus-map")
    assert rc == 0, text
    assert re.search(r"^  4, 0, 255  in1 \(generic slave\)$", text, re.M), text
    assert re.search(r"^  5  in2 \(generic slave\)$", text, re.M), text
    assert "in2  outputs Q 8..15" in text, text
    assert "forced CAN state" not in text, text  # no gateway: no CAN fault registers
    rc, out = run(candp2_binary, "--config", CONFIG, "--print-modbus-map", "--json")
    assert rc == 0, out
    m = json.loads(out)
    assert m["gateways"] == [] and m["drives"] == []
    assert [s["units"] for s in m["slaves"]] == [[4, 0, 255], [5]]


def test_the_faces_of_a_line_of_slaves(candp2_binary, tmp_path):
    config = line_config()
    capture = tmp_path / "line.pcapng"
    config["capture"] = {"pcapng": str(capture)}
    d = Daemon(candp2_binary, config=config)
    try:
        s = d.wait_for("both slaves in Data_Exch", lambda s: [
            (x["name"], x["dp_state"], x["master"]["state"]) for x in s["slaves"]] == [
            ("in1", "Data_Exch", "Data_Exch"), ("in2", "Data_Exch", "Data_Exch")])
        assert s["gateways"] == [] and s["buses"] == [], s
        assert d.socketcand == {}

        # in1's PLC outputs Q 0..3 (unit 4, holding registers 0..1) reach its field side.
        mbpoll(d, 4, 4, 0, "0x1122", "0x3344")
        d.slave("in1").wait_until(lambda x: x.field_outputs[0:4] == bytes.fromhex("11223344"))
        assert mbpoll(d, 104, 3, 0, count=2) == {0: 0x1122, 1: 0x3344}
        # in2's field inputs (unit 105) reach the PLC image I 8..9 (input register 4), read
        # through unit 0, which addresses the first slave here.
        mbpoll(d, 105, 4, 0, "0xA55A")
        d.slave("in2").wait_until(lambda x: x.inputs[8:10] == b"\xA5\x5A")
        assert mbpoll(d, 0, 3, 4) == {4: 0xA55A}
        dp_address = d.register_map.fields["dp_address"].register
        assert mbpoll(d, 255, 3, dp_address) == {dp_address: 4}

        code, _, body = d.get("/metrics")
        assert code == 200
        metrics = body.decode()
        for name in ("in1", "in2"):
            assert re.search(r'^candp2_slave_dp_state\{[^}]*name="%s"[^}]*\} 2$' % name,
                             metrics, re.M), metrics
        event = first_event(d.http_port, "slave=4")
        assert [t["name"] for t in event["slaves"]] == ["in1", "in2"], event
        assert event["slave"]["name"] == "in1" and not event.get("gateways"), event
        code, _, page = d.get("/")
        assert code == 200 and b"<html" in page.lower()
    finally:
        d.stop()
    assert d.returncode == 0, d.log
    assert packets(capture) > 10  # the master's services to both slaves as FDL telegrams


def line_config():
    """config/slaves-line.json with the GSD paths made absolute (the Daemon runs a copy)."""
    with open(CONFIG) as f:
        config = json.load(f)
    for s in config["slaves"]:
        s["gsd"] = os.path.join(ROOT, "config", s["gsd"])
    return config


def test_both_wire_roles_without_a_gateway(candp2_binary, tmp_path):
    link = str(tmp_path / "pb")
    served = line_config()  # S: the slaves answer an external master on the pty
    served["profibus"] = {"port": "pty:" + link, "baud": 19200, "role": "slaves"}
    del served["master"]
    master = line_config()  # M: the built-in master drives them there as remote stations
    master["master"] = {"address": 1, "cycle_ms": 5, "retry_ms": 100}
    master["profibus"] = {"port": link, "baud": 19200, "role": "master"}
    for sl in master["slaves"]:
        del sl["field_unit"]  # a remote station has no field side here
    with candp2.Daemon(served, candp2_binary) as s, candp2.Daemon(master, candp2_binary) as m:
        for name in ("in1", "in2"):
            m.slave(name).wait_until(lambda x: x.master_state == "Data_Exch", timeout=WAIT)
            s.slave(name).wait_until(lambda x: x.state == "Data_Exch", timeout=WAIT)
        m.slave("in2").outputs[8:10] = b"\x5A\xA5"      # M's PLC outputs reach S's slave
        s.slave("in2").wait_until(lambda x: x.field_outputs[0:2] == b"\x5A\xA5", timeout=WAIT)
        s.slave("in1").field_inputs[0:2] = b"\x12\x34"  # S's field inputs reach M's image
        m.slave("in1").wait_until(lambda x: x.inputs[0:2] == b"\x12\x34", timeout=WAIT)
        assert m.gateways() == [] and s.gateways() == []


def test_the_page_opens_on_the_overview(candp2_binary):
    d = Daemon(candp2_binary, config=line_config())
    browser = None
    try:
        d.wait_for("both slaves in Data_Exch",
                   lambda s: [x["dp_state"] for x in s["slaves"]] == ["Data_Exch"] * 2)
        browser = Browser(os.environ.get("CHROMIUM", "/usr/bin/chromium"))
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        browser.wait_for("two slave tiles and nothing else",
                         "document.querySelectorAll('#tiles .tile').length === 2 && "
                         "document.querySelectorAll('#tiles .tile.slave').length === 2 && "
                         "document.getElementById('scount').textContent === '2'")
        assert browser.evaluate("location.hash") == "", "opened a panel instead of the overview"
        assert browser.evaluate("document.getElementById('count').parentElement.hidden") is True
        browser.evaluate("document.getElementById('tile-4').click()")
        browser.wait_for("in1's panel with its one module",
                         "location.hash === '#slave=4' && "
                         "document.querySelectorAll('#slave-4 .modules tbody tr').length === 1")
    finally:
        if browser:
            browser.close()
        d.stop()
