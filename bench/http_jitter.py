#!/usr/bin/python3
"""DP master cycle jitter with and without live-page clients (docs/daemon.md
"Measurements").

Runs candp2d with N gateways (default 122, DP addresses 3..124) on one virtual bus, master cycle
10 ms, HTTP on a free port; a Modbus writer changes every gateway's output bytes every 100 ms, so
each write puts N frames on the bus. Each phase lasts --seconds (>= 42 s so the daemon's window of
the last 4096 cycles holds only that phase) and then reads the cycle lateness (start time minus
the 10 ms grid point: p50, p99, max) from GET /api/v1/status:

  phase "none":    no HTTP clients;
  phase "clients": --sse plain SSE clients reading /api/v1/events, plus one headless chromium
                   showing the page, the overview (--no-chromium to leave it out).

bench/http_load.py measures missed cycles, 122 x 48 slots and 1/2/10 ms as well.

Usage: bench/http_jitter.py --candp2d build/bin/candp2d [--gateways 122] [--seconds 45] [--fifo]
"""

import argparse
import json
import os
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "e2e"))
# tests/e2e is on sys.path at run time only, and untyped: mypy sees its names as Any.
from cdp import Browser  # type: ignore[import]  # noqa: E402
from http_common import Daemon, SseReader  # type: ignore[import]  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402  python3-pymodbus


def config(n: int) -> dict[str, object]:
    gws: list[dict[str, object]] = []
    for i in range(n):
        a = 3 + i
        tx, rx = 0x400 + a, 0x500 + a
        gws.append({"name": "gw%d" % a, "address": a, "bus": "can0",
                    "parameters": {"can_bitrate": "500k"},
                    "slots": [{"io": "output", "address": 2 * a, "length": 2,
                               "comment": "%02X,%02X,00" % (tx >> 8, tx & 0xFF)},
                              {"io": "input", "address": 2 * a, "length": 2,
                               "comment": "%02X,%02X,00" % (rx >> 8, rx & 0xFF)}]})
    return {"modbus": {"listen": "127.0.0.1:0"}, "http": {"listen": "127.0.0.1:0"},
            "master": {"address": 1, "cycle_ms": 10},
            "buses": {"can0": {"type": "virtual"}}, "gateways": gws, "log": {"level": "info"}}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--gateways", type=int, default=122)
    ap.add_argument("--seconds", type=float, default=45)
    ap.add_argument("--sse", type=int, default=5)
    ap.add_argument("--no-chromium", action="store_true")
    ap.add_argument("--order", default="none,clients,none")
    ap.add_argument("--fifo", action="store_true",
                    help="run candp2d under chrt -f 20 (SCHED_FIFO, as docs/daemon.md suggests)")
    args = ap.parse_args()

    cfg = config(args.gateways)
    d = Daemon(args.candp2d, config=cfg, timeout=60,
               prefix=("chrt", "-f", "20") if args.fifo else ())
    writer_stop = False

    def writer() -> None:
        mb = ModbusTcpClient("127.0.0.1", port=d.modbus_port, timeout=3)
        mb.connect()
        k = 0
        while not writer_stop:
            k += 1
            # Q bytes 6..2*126: every gateway's two output bytes (register r = bytes 2r, 2r+1).
            first, last = 3, 3 + args.gateways - 1
            regs = [(k * 7 + r) & 0xFFFF for r in range(first, last + 1)]
            for off in range(0, len(regs), 120):
                mb.write_registers(first + off, regs[off:off + 120], slave=3)
            time.sleep(0.1)
        mb.close()

    results: list[dict[str, object]] = []
    try:
        d.wait_for("every gateway in Data_Exch",
                   lambda s: all(g["dp_state"] == "Data_Exch" for g in s["gateways"]), timeout=60)
        wt = threading.Thread(target=writer, daemon=True)
        wt.start()
        for phase in args.order.split(","):
            readers: list[SseReader] = []
            browser: Browser | None = None
            if phase == "clients":
                readers = [SseReader(d.http_port) for _ in range(args.sse)]
                for r in readers:
                    r.start()
                if not args.no_chromium:
                    browser = Browser(width=1400, height=1000)
                    browser.call("Page.navigate", url=d.base + "/")
            t0 = time.monotonic()
            time.sleep(args.seconds)
            t = time.monotonic() - t0
            s = d.status()
            lat = s["cycle"]["lateness_us"]
            t1 = time.monotonic()
            code, _, body = d.get("/api/v1/status")
            get_ms = (time.monotonic() - t1) * 1000
            row = {"phase": phase, "samples": lat["samples"], "p50_us": lat["p50"],
                   "p99_us": lat["p99"], "max_us": lat["max"], "snapshot_bytes": len(body),
                   "get_status_ms": round(get_ms, 1),
                   "snapshot_build_us": s["http"]["last_build_us"],
                   "snapshots_dropped": s["http"]["snapshots_dropped"],
                   "frames_per_s": round(s["buses"][0]["frames_per_s"]),
                   "sse_events_per_client_per_s": round(
                       sum(r.events for r in readers) / max(1, len(readers)) / t, 1),
                   "sse_mbytes_per_s": round(sum(r.bytes for r in readers) / t / 1e6, 2),
                   "loadavg": os.getloadavg()[0]}
            if browser:
                row["chromium_shows_gateways"] = browser.evaluate(
                    "document.querySelectorAll('#tiles .tile').length")
                browser.close()
            for r in readers:
                r.stop.set()
            results.append(row)
            print(json.dumps(row), flush=True)
    finally:
        writer_stop = True
        d.stop()


if __name__ == "__main__":
    main()
