#!/usr/bin/python3
"""Watching must not disturb (docs/daemon.md "Measurements"): the DP master cycle of the
largest line the product allows while the HTTP face is watched.

candp2d runs 122 gateways x 48 six-byte slots (tests/e2e/http_common.line_config) and a Modbus
client changes every output byte every 100 ms (bench/line_load.py does the same). For each master
cycle time (--cycles) and binary (--a, --b, alternating per round) one daemon runs the phases
(--phases) one after the other, --seconds each, so that they see the same machine:

  none      no HTTP client
  sse1      one Server-Sent Events client on /api/v1/events (the overview)
  sse5      five of them
  browser   one headless chromium showing the overview (tests/e2e/cdp.py)

Per phase, from /metrics (read every 3 s, so the daemon's window of the last 4096 cycles covers
the phase at 1 ms): cycles run, grid points due (cycles + missed, or the elapsed time / cycle for
a binary without candp2_master_cycles_missed_total), missed cycles, lateness p99 (median and
maximum of the readings) and max; candp2d's CPU (utime + stime); the SSE clients' bytes/s each.

--bytes measures bytes/s of one stream for the demo (config/demo.json) and for 122 x 48, each for
the overview and for one open panel (?gw=3, ?gw=17), 20 s each.

--floor build/bin/cycle_floor runs bench/cycle_floor.cpp before each daemon: the grid points a
thread that does nothing but wake every cycle misses on this machine (the floor no program beats).

Usage: bench/http_load.py --a build/bin/candp2d [--b OTHER/candp2d] [--cycles 1,2,10]
       [--phases none,sse1,sse5,browser] [--seconds 60] [--rounds 1] [--fifo] [--bytes]
       [--floor build/bin/cycle_floor] [--no-writer]
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import threading
import time
import urllib.request
from typing import Any, TypedDict

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "e2e"))
# tests/e2e is on sys.path at run time only, and untyped: mypy sees its names as Any.
from cdp import Browser  # type: ignore[import]  # noqa: E402
from http_common import (  # type: ignore[import]  # noqa: E402
    Daemon, SseReader, demo_config, line_config)

from pymodbus.client import ModbusTcpClient  # noqa: E402  python3-pymodbus


class Writer(threading.Thread):
    """Changes every output byte of the image every 100 ms (bench/line_load.py)."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port, self.stop = port, threading.Event()

    def run(self) -> None:
        mb = ModbusTcpClient("127.0.0.1", port=self.port, timeout=5)
        mb.connect()
        k = 0
        while not self.stop.is_set():
            k += 1
            for first in range(0, 4000, 120):
                mb.write_registers(first, [(k * 31 + first + j) & 0xFFFF for j in range(120)],
                                   slave=3)
            self.stop.wait(0.1)
        mb.close()


def metrics(d: Daemon) -> dict[str, float]:
    with urllib.request.urlopen(d.base + "/metrics", timeout=30) as r:
        text = r.read().decode()
    out: dict[str, float] = {}
    for name, key in (("candp2_master_cycles_total", "cycles"),
                      ("candp2_master_cycles_missed_total", "missed"),
                      ('candp2_master_cycle_lateness_seconds{quantile="0.99"}', "p99"),
                      ('candp2_master_cycle_lateness_seconds{quantile="1"}', "max")):
        m = re.search("^%s (\\S+)$" % re.escape(name), text, re.M)
        if m:
            out[key] = float(m.group(1))
    return out


def cpu_ticks(pid: int) -> int:
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


class Phase(TypedDict):
    """What phase() measured, in the order it is printed."""
    phase: str
    cycles: int
    due: int
    missed: int
    window_inside_phase: bool
    p99_us_median: int
    p99_us_max: int
    max_us: int
    cpu_pct: float
    bytes_per_s_each: list[int]


def phase(d: Daemon, name: str, cycle_ms: int, seconds: float, chromium: str) -> Phase:
    readers: list[SseReader] = []
    browser: Browser | None = None
    if name.startswith("sse"):
        readers = [SseReader(d.http_port) for _ in range(int(name[3:]))]
        for r in readers:
            r.start()
    elif name == "browser":
        browser = Browser(chromium, width=1400, height=1000)
        browser.call("Page.enable")
        browser.call("Page.navigate", url=d.base + "/")
        # (A build before the overview has no "drawn" mark: its first snapshot then.)
        browser.wait_for("the page",
                         "document.body.dataset.drawn || document.body.dataset.snapshot",
                         timeout=120)
    try:
        time.sleep(2.0)  # the clients settle (a browser's first paint)
        b0 = [r.bytes for r in readers]
        m0, c0, t0 = metrics(d), cpu_ticks(d.pid), time.monotonic()
        # The daemon's lateness window is the last 4096 cycles: only readings whose window lies
        # inside this phase count (after 41 s at 10 ms, 4 s at 1 ms); else the last reading.
        window = 4096 * cycle_ms / 1000.0
        readings: list[tuple[float, float, float]] = []  # (s into the phase, p99 us, max us)
        while time.monotonic() - t0 < seconds:
            time.sleep(min(3.0, max(0.0, seconds - (time.monotonic() - t0))))
            m = metrics(d)
            readings.append((time.monotonic() - t0, m["p99"] * 1e6, m["max"] * 1e6))
        inside = [r for r in readings if r[0] >= window]
        clean = bool(inside)
        p99s = [r[1] for r in (inside or readings[-1:])]
        maxes = [r[2] for r in (inside or readings[-1:])]
        m1, c1, t1 = metrics(d), cpu_ticks(d.pid), time.monotonic()
        b1 = [r.bytes for r in readers]
    finally:
        for r in readers:
            r.stop.set()
        if browser:
            browser.close()
    cycles = m1["cycles"] - m0["cycles"]
    if "missed" in m1:
        missed = m1["missed"] - m0["missed"]
        due = cycles + missed
    else:  # a binary that does not count them: the grid points the elapsed time offered
        due = round((t1 - t0) * 1000.0 / cycle_ms)
        missed = max(0, due - cycles)
    return {"phase": name, "cycles": int(cycles), "due": int(due), "missed": int(missed),
            "window_inside_phase": clean,
            "p99_us_median": round(statistics.median(p99s)), "p99_us_max": round(max(p99s)),
            "max_us": round(max(maxes)),
            "cpu_pct": round(100.0 * (c1 - c0) / os.sysconf("SC_CLK_TCK") / (t1 - t0), 1),
            "bytes_per_s_each": [round((b - a) / (t1 - t0)) for a, b in zip(b0, b1)]}


def run(binary: str, cycle_ms: int, phases: list[str], seconds: float,
        wrapper: tuple[str, ...], chromium: str, write: bool = True) -> list[dict[str, object]]:
    d = Daemon(binary, config=line_config(cycle_ms), timeout=60, prefix=wrapper)
    rows: list[dict[str, object]] = []
    try:
        d.wait_for("every gateway in Data_Exch",
                   lambda s: all(g["dp_state"] == "Data_Exch" for g in s["gateways"]), timeout=60)
        w = Writer(d.modbus_port)
        if write:
            w.start()
        try:
            for name in phases:
                rows.append({"cycle_ms": cycle_ms, **phase(d, name, cycle_ms, seconds, chromium)})
        finally:
            w.stop.set()
            if write:
                w.join(10)
    finally:
        d.stop()
    return rows


def stream_bytes(binary: str, config: dict[str, Any], query: str, seconds: float,
                 wrapper: tuple[str, ...]) -> int:
    d = Daemon(binary, config=config, timeout=60, prefix=wrapper)
    try:
        d.wait_for("every gateway in Data_Exch",
                   lambda s: all(g["dp_state"] == "Data_Exch" for g in s["gateways"]), timeout=60)
        w = Writer(d.modbus_port)
        w.start()
        r = SseReader(d.http_port, query)
        r.start()
        time.sleep(2.0)
        b0, t0 = r.bytes, time.monotonic()
        time.sleep(seconds)
        b1, t1 = r.bytes, time.monotonic()
        r.stop.set()
        w.stop.set()
        bps: int = round((b1 - b0) / (t1 - t0))
        return bps
    finally:
        d.stop()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--a", required=True, help="candp2d binary A")
    ap.add_argument("--b", help="candp2d binary B (alternating with A)")
    ap.add_argument("--cycles", default="1,2,10")
    ap.add_argument("--phases", default="none,sse1,sse5,browser")
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--fifo", action="store_true", help="run candp2d under chrt -f 20")
    ap.add_argument("--bytes", action="store_true", help="bytes/s of one stream, demo and 122x48")
    ap.add_argument("--no-writer", action="store_true", help="no Modbus writes (no CAN traffic)")
    ap.add_argument("--floor", help="bench/cycle_floor.cpp's binary: the machine's own floor for "
                    "a periodic task, run for --seconds before each daemon")
    ap.add_argument("--chromium", default=os.environ.get("CHROMIUM", "/usr/bin/chromium"))
    args = ap.parse_args()
    wrapper: tuple[str, ...] = ("chrt", "-f", "20") if args.fifo else ()
    binaries = [("A", args.a)] + ([("B", args.b)] if args.b else [])
    if args.bytes:
        for name, binary in binaries:
            for label, cfg, query in (("demo overview", demo_config(), ""),
                                      ("demo panel ?gw=3", demo_config(), "?gw=3"),
                                      ("122x48 overview", line_config(10), ""),
                                      ("122x48 panel ?gw=17", line_config(10), "?gw=17")):
                bps = stream_bytes(binary, cfg, query, 20, wrapper)
                print(json.dumps({"binary": name, "stream": label, "bytes_per_s": bps}),
                      flush=True)
        return
    phases = args.phases.split(",")
    for cycle in [int(c) for c in args.cycles.split(",")]:
        for _ in range(args.rounds):
            for name, binary in binaries:
                if args.floor:
                    out = subprocess.run(list(wrapper) + [args.floor, str(args.seconds),
                                                          str(cycle * 1000)],
                                         capture_output=True, text=True, check=True).stdout
                    print(json.dumps({"binary": "floor", "fifo": args.fifo, "cycle_ms": cycle,
                                      **json.loads(out)}), flush=True)
                for row in run(binary, cycle, phases, args.seconds, wrapper, args.chromium,
                               not args.no_writer):
                    print(json.dumps({"binary": name, "fifo": args.fifo,
                                      "writer": not args.no_writer, **row}), flush=True)


if __name__ == "__main__":
    main()
