"""Shared by the HTTP face's end-to-end tests (http_*_e2e.py) and bench/http_jitter.py,
bench/http_load.py, bench/line_load.py: a candp2.Daemon (python/: every listener on a free
loopback port, learnt from READY=1) with helpers for its HTTP face, and a reader of its event
stream that counts what it receives.
"""

import json
import os
import socket
import sys
import threading
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python"))
import candp2  # noqa: E402


def demo_config():
    """config/demo.json (the Daemon moves its listeners to free ports)."""
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        return json.load(f)


# docs/profibus.md "Line statistics": the counters of a station, in the table's order.
STATION_COUNTERS = ["lost", "syncs", "repeats", "repeats_max", "illegals", "diagnostics"]

LINE_GATEWAYS = 122  # DP addresses 3..124: the largest line the product allows
LINE_SLOTS = 24      # outputs and as many inputs per gateway, 6 bytes each
SLOT_LEN = 6


def line_slot_address(gateway, k):
    """PLC byte address of output (and input) slot k of the gateway at DP address `gateway` in
    line_config(): the 8192-byte image is shared, so the gateways' slots overlap (allowed,
    docs/modbus.md) and one Modbus write reaches them all."""
    return (k * SLOT_LEN + (gateway - 3) * 8) % 8000


def line_config(cycle_ms=10, gateways=LINE_GATEWAYS):
    """122 gateways x 48 six-byte slots (24 outputs, 24 inputs: 288 of the 300 bytes a gateway
    allows), each on its own virtual bus (bench/line_load.py, tests/e2e/http_scale_e2e.py)."""
    gws, buses = [], {}
    for i in range(gateways):
        a = 3 + i
        bus = "can%d" % a
        buses[bus] = {"type": "virtual"}
        slots = []
        for io, base in (("output", 0x100), ("input", 0x300)):
            for k in range(LINE_SLOTS):
                ident = base + k
                slots.append({"io": io, "address": line_slot_address(a, k), "length": SLOT_LEN,
                              "comment": "%02X,%02X,00" % (ident >> 8, ident & 0xFF)})
        gws.append({"name": "gw%d" % a, "address": a, "bus": bus,
                    "parameters": {"can_bitrate": "1000k"}, "slots": slots})
    return {"modbus": {"listen": "127.0.0.1:0"}, "http": {"listen": "127.0.0.1:0"},
            "master": {"address": 1, "cycle_ms": cycle_ms}, "buses": buses, "gateways": gws,
            "log": {"level": "info"}}


class SseReader(threading.Thread):
    """Reads one event stream (/api/v1/events with `query`, "?gw=3" say) until stop.set(),
    counting its bytes and its status events."""

    def __init__(self, port, query=""):
        super().__init__(daemon=True)
        self.port, self.query = port, query
        self.bytes, self.events, self.stop = 0, 0, threading.Event()

    def run(self):
        s = socket.create_connection(("127.0.0.1", self.port), timeout=5)
        s.sendall(b"GET /api/v1/events%s HTTP/1.1\r\nHost: x\r\n\r\n" % self.query.encode())
        s.settimeout(0.5)
        while not self.stop.is_set():
            try:
                b = s.recv(1 << 20)
            except socket.timeout:
                continue
            if not b:
                break
            self.bytes += len(b)
            self.events += b.count(b"event: status")
        s.close()


class Daemon(candp2.Daemon):
    """candp2d running `config` (default: config/demo.json); `prefix` runs it under another
    program (chrt)."""

    def __init__(self, candp2d, config=None, timeout=15.0, prefix=()):
        super().__init__(demo_config() if config is None else config, candp2d,
                         timeout=timeout, wrapper=tuple(prefix))
        self.modbus_port = self.modbus_address[1]
        self.http_port = self.http_address[1]
        self.base = self.http_url

    def get(self, path, method="GET", timeout=5.0):
        """(status, headers, body bytes); HTTP errors are returned, not raised."""
        req = urllib.request.Request(self.base + path, method=method,
                                     data=b"x" if method in ("POST", "PUT") else None)
        try:
            with urllib.request.urlopen(req, timeout=timeout) as r:
                return r.status, r.headers, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers, e.read()

    def status(self):
        code, _, body = self.get("/api/v1/status")
        assert code == 200, code
        return json.loads(body)

    def wait_for(self, what, predicate, timeout=10.0):
        """Polls /api/v1/status until predicate(status) is true (then returns the status)."""
        end = time.monotonic() + timeout
        while True:
            s = self.status()
            if predicate(s):
                return s
            if time.monotonic() > end:
                raise AssertionError("%s not within %.0f s; last status:\n%s"
                                     % (what, timeout, json.dumps(s)[:2000]))
            time.sleep(0.02)

    def stop(self, timeout=10.0, check=False):
        return super().stop(timeout, check)
