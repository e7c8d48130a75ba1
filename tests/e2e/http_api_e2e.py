"""candp2d's HTTP face (docs/daemon.md "HTTP face") against the running demo daemon
(pytest on the candp2 package; ctest e2e_http_api):

  - GET /api/v1/status: the gateway's state, diagnosis, LEDs, counters and slot bytes; after a
    Modbus write of Q 0..4 (docs/modbus.md) the output slot shows the written bytes and its Tx
    count moves; the numbers agree with the Modbus status block;
  - read-only: POST, PUT, DELETE get 405 with "Allow: GET, HEAD"; unknown paths 404;
  - GET /metrics parsed by Debian's python3-prometheus-client with values asserted;
  - GET /api/v1/events: Server-Sent Events, rate-limited (never faster than every 100 ms);
    `?once`: the first (full) event and the end of the answer, with the panel asked for;
  - a stalled SSE client (never reads) does not hold up the others: they keep receiving and
    requests are answered; closing it ends its stream.

The tests run in file order against one daemon; the only Modbus client is the package's own.
"""

import json
import os
import socket
import sys
import time

import pytest
from prometheus_client.parser import text_string_to_metric_families  # python3-prometheus-client

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from http_common import Daemon  # noqa: E402

UNIT = 3
# Unitek REGID 0x3D with 0x30, period 0: read the actual speed once (Unitek manual example 10).
COMMAND = [0x3D, 0x30, 0x00, 0x00, 0x00]


def gateway(s):
    return next(g for g in s["gateways"] if g["dp_address"] == UNIT)


def slot_at(g, plc):
    return next(x for x in g["slots"] if x["plc"] == plc)


@pytest.fixture(scope="module")
def d(candp2_binary):
    daemon = Daemon(candp2_binary)
    try:
        yield daemon
    finally:
        daemon.stop()


@pytest.fixture(scope="module")
def gw(d):
    """Gateway 3 through the package: its image and status block over Modbus."""
    return d.gateway(UNIT)


def test_1_status(d, gw):
    s = d.wait_for("gateway 3 in Data_Exch", lambda s: gateway(s)["dp_state"] == "Data_Exch")
    g = gateway(s)
    # manual table 3.3.1: LED D on in Data_Exch, P on, E off (no flashing), C on (CAN ok).
    assert g["leds"] == {"P": 1, "D": 1, "E": 0, "C": 1}, g["leds"]
    assert len(g["diag"]) == 11 and g["diag"][4:8] == [0x04, 0xA4, 0x05, 0x04], g["diag"]
    assert g["parameters"]["bitrate"] == 500000 and g["parameters"]["accepted"], g["parameters"]
    assert [x["dir"] for x in g["slots"]] == ["tx", "tx", "rx", "rx"], g["slots"]
    out = slot_at(g, "Q0")
    assert out["id"] == 0x201 and not out["extended"] and out["length"] == 5, out
    tx_before = out["frames"]

    gw.outputs[0:5] = bytes(COMMAND)  # Q 0..4: slot Q0
    want = " ".join("%02X" % b for b in COMMAND)
    s = d.wait_for("the written bytes in slot Q0",
                   lambda s: slot_at(gateway(s), "Q0")["bytes"] == want
                   and slot_at(gateway(s), "Q0")["frames"] > tx_before)
    # The drive answers on 0x181 (input slot I0): REGID 0x30 first.
    s = d.wait_for("the drive's reply in slot I0",
                   lambda s: slot_at(gateway(s), "I0")["bytes"].startswith("30 ")
                   and slot_at(gateway(s), "I0")["frames"] > 0)
    i0 = slot_at(gateway(s), "I0")
    assert i0["age_ms"] is not None and 0 <= i0["age_ms"] < 10000, i0
    # The same counters as the Modbus status block (docs/modbus.md: tx_frames), read between two
    # status requests: before <= modbus <= after.
    before = gateway(d.status())["counters"]["tx_frames"]
    modbus = gw.counters.tx_frames
    after = gateway(d.status())["counters"]["tx_frames"]
    assert before <= modbus <= after, (before, modbus, after)
    s = d.status()
    assert s["modbus"]["requests"] >= 2 and s["modbus"]["clients"] == 1, s["modbus"]
    # The trace shows the command frame on the bus.
    bus = next(b for b in s["buses"] if b["name"] == "can0")
    assert any(f["id"] == 0x201 and f["data"] == want for f in bus["trace"]), bus["trace"]
    assert bus["bitrate"] == 500000 and bus["frames"] >= 2, bus
    print("status: ok (slot Q0 = %s, I0 = %s)" % (want, i0["bytes"]))


def test_2_methods(d):
    for m in ("POST", "PUT", "DELETE"):
        code, headers, body = d.get("/api/v1/status", method=m)
        assert code == 405, (m, code)
        assert headers["Allow"] == "GET, HEAD", headers
    code, _, _ = d.get("/no/such/page")
    assert code == 404, code
    code, headers, body = d.get("/")
    assert code == 200 and b"<title>candp2" in body, body[:200]
    assert headers["Content-Type"].startswith("text/html"), headers
    for path in ("/panel.js", "/panel.css"):
        code, _, body = d.get(path)
        assert code == 200 and len(body) > 1000, (path, code)
    print("methods and paths: ok")


def test_3_metrics(d, gw):
    assert gw.state == "Data_Exch"  # one more Modbus request: counted
    code, headers, body = d.get("/metrics")
    assert code == 200, code
    assert headers["Content-Type"].startswith("text/plain; version=0.0.4"), headers
    families = {f.name: f for f in text_string_to_metric_families(body.decode())}

    def value(family, **labels):
        f = families[family]
        for s in f.samples:
            if all(s.labels.get(k) == v for k, v in labels.items()):
                return s.value
        raise AssertionError("%s%s not in %s" % (family, labels, f.samples))

    s = d.status()
    g = gateway(s)
    assert families["candp2_gateway_dp_state"].type == "gauge"
    assert value("candp2_gateway_dp_state", gateway="3", bus="can0") == 2
    assert families["candp2_gateway_data_exchanges"].type == "counter"
    dx = value("candp2_gateway_data_exchanges", gateway="3", bus="can0")
    assert 0 < dx <= g["counters"]["data_exchanges"], (dx, g["counters"])
    sent = value("candp2_gateway_can_frames_sent", gateway="3", bus="can0")
    assert 2 <= sent <= g["counters"]["tx_frames"], (sent, g["counters"])
    assert value("candp2_gateway_can_frames_lost", gateway="3", reason="fifo") == 0
    assert value("candp2_gateway_fifo_level", gateway="3") == 0
    req = value("candp2_modbus_requests", result="ok")
    assert req >= 3 and req <= s["modbus"]["requests"], (req, s["modbus"])
    assert value("candp2_modbus_clients") == 1
    assert value("candp2_bus_frames", bus="can0") >= 3
    assert value("candp2_master_cycles") > 0
    print("metrics: ok (%d families, %d Data_Exchanges)" % (len(families), dx))


def test_4_events(d):
    """Reads the SSE stream for 1.5 s: snapshots arrive, at most one per 100 ms."""
    sock = socket.create_connection(("127.0.0.1", d.http_port), timeout=5)
    sock.sendall(b"GET /api/v1/events HTTP/1.1\r\nHost: x\r\nAccept: text/event-stream\r\n\r\n")
    data = b""
    end = time.monotonic() + 1.5
    while time.monotonic() < end:
        sock.settimeout(max(0.01, end - time.monotonic()))
        try:
            chunk = sock.recv(65536)
        except socket.timeout:
            break
        if not chunk:
            break
        data += chunk
    sock.close()
    head, _, body = data.partition(b"\r\n\r\n")
    assert b" 200 " in head.split(b"\r\n")[0] and b"text/event-stream" in head, head
    events = body.count(b"event: status\ndata: ")
    assert 2 <= events <= 1.5 / 0.1 + 1, events
    first = body.split(b"data: ", 1)[1].split(b"\n", 1)[0]
    assert json.loads(first)["gateways"][0]["dp_address"] == UNIT
    print("events: ok (%d snapshots in 1.5 s)" % events)


def test_4_events_once(d):
    """?once (the page's first render): one full event, then the answer ends by itself."""
    for query, panel in (("?once", False), ("?gw=%d&once" % UNIT, True)):
        t0 = time.monotonic()
        code, headers, body = d.get("/api/v1/events" + query, timeout=5)
        took = time.monotonic() - t0
        assert code == 200 and headers["Content-Type"] == "text/event-stream", (code, headers)
        assert body.count(b"event: status\ndata: ") == 1 and body.endswith(b"\n\n"), body[:300]
        e = json.loads(body.split(b"data: ", 1)[1].split(b"\n", 1)[0])
        assert e["full"] is True and e["gateways"][0]["dp_address"] == UNIT, e
        assert ("open" in e) == panel, sorted(e)
        if panel:
            assert e["open"] == UNIT and e["panel"]["slot_count"] == len(e["slots"]) == 4, e
        print("events%s: one event of %d bytes in %.0f ms" % (query, len(body), 1000 * took))


def read_events(port, seconds):
    sock = socket.create_connection(("127.0.0.1", port), timeout=5)
    sock.sendall(b"GET /api/v1/events HTTP/1.1\r\nHost: x\r\n\r\n")
    data = b""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        sock.settimeout(max(0.01, end - time.monotonic()))
        try:
            chunk = sock.recv(65536)
        except socket.timeout:
            break
        if not chunk:
            break
        data += chunk
    sock.close()
    return data.count(b"event: status\ndata: ")


def test_5_stalled_client(d):
    stalled = socket.socket()
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    stalled.connect(("127.0.0.1", d.http_port))
    stalled.sendall(b"GET /api/v1/events HTTP/1.1\r\nHost: x\r\n\r\n")
    try:
        d.wait_for("the stalled stream counted", lambda s: s["http"]["sse_clients"] == 1)
        dropped = d.status()["http"]["snapshots_dropped"]
        # Meanwhile another client gets its snapshots and plain requests are answered.
        events = read_events(d.http_port, 2.0)
        assert events >= 3, events
        t = time.monotonic()
        d.status()
        assert time.monotonic() - t < 1.0
        # (Whether snapshots are already being dropped depends on the kernel's loopback buffers,
        # which hold many small demo snapshots; only reported.)
        s = d.status()
        print("stalled client: ok (other client got %d snapshots; %d dropped so far)"
              % (events, s["http"]["snapshots_dropped"] - dropped))
    finally:
        stalled.close()
    d.wait_for("the stalled stream closed", lambda s: s["http"]["sse_clients"] == 0)
