#!/usr/bin/python3
"""The largest line the product allows, measured from outside (docs/daemon.md "Measurements").

candp2d runs 122 gateways (DP addresses 3..124), each with 48 six-byte slots (24 outputs, 24
inputs: 288 of the 300 bytes a gateway allows) on its own virtual CAN bus; a Modbus client
changes every output byte of the image every 100 ms, so each write makes every gateway send all
its 24 frames. For each master cycle time (--cycles, default 1,2,10 ms) and each binary (--a,
--b: alternating A, B, A, B ... --rounds times, so that both see the same machine), one run of
--seconds measures:

  cycles_done / cycles_due  master cycles run against the cycles the grid offered (missed ones
                            show as the difference)
  p99_us, max_us            cycle start lateness against the grid (GET /api/v1/status)
  cpu_pct                   candp2d's CPU time over the run (utime + stime, /proc/PID/stat)
  rss_kb, hwm_kb            resident memory at the end and its high-water mark (/proc/PID/status)
  frames                    CAN frames the gateways sent over the run (sum over the buses)
  bus_cycle_us              on a line in time (--lines with a baud rate): the measured bus cycle
                            (mean, max) from GET /api/v1/status line
  events_bytes              with --observer: bytes the open panel's event stream received
  poll_errors               with --observer: status polls that failed during the run (0)

--lines ideal,12000000 runs each binary on the ideal line and on a line in time at that baud
rate (docs/profibus.md "The line in time"), A/B in one run; --observer keeps a panel open over
the run (GET /api/v1/events read continuously, GET /api/v1/status twice a second, as the
panel's line view does).

Prints one JSON line per run and a summary (medians per binary, line and cycle time).

Usage: bench/line_load.py --a build/bin/candp2d [--b OTHER/candp2d] [--seconds 10] [--rounds 2]
       [--cycles 1,2,10] [--lines ideal,12000000] [--observer]
"""

import argparse
import http.client
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from typing import Any, Literal, TypedDict

from pymodbus.client import ModbusTcpClient  # noqa: E402  python3-pymodbus

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "e2e"))
# tests/e2e is on sys.path at run time only, and untyped: mypy sees its names as Any.
from http_common import line_config  # type: ignore[import]  # noqa: E402


def config(cycle_ms: int, baud: int | None = None) -> dict[str, Any]:
    """122 x 48 six-byte slots (tests/e2e/http_common.line_config), quieter log; with `baud` a
    line in time."""
    cfg: dict[str, Any] = line_config(cycle_ms)
    cfg["log"] = {"level": "warn"}
    if baud:
        cfg["master"]["baud"] = baud
    return cfg


class Observer:
    """An open panel: its event stream (`stream`) read continuously, the status document twice a
    second (unless `poll` is false: a second view of the same page)."""

    def __init__(self, http_port: int, stream: str = "/api/v1/events", poll: bool = True) -> None:
        self.port, self.bytes, self.stop = http_port, 0, threading.Event()
        self.stream, self.poll_errors = stream, 0
        self.threads = [threading.Thread(target=self.events, daemon=True)]
        if poll:
            self.threads.append(threading.Thread(target=self.poll, daemon=True))
        for t in self.threads:
            t.start()

    def events(self) -> None:
        try:
            with urllib.request.urlopen("http://127.0.0.1:%d%s" % (self.port, self.stream),
                                        timeout=30) as r:
                while not self.stop.is_set():
                    chunk = r.read1(65536)
                    if not chunk:
                        break
                    self.bytes += len(chunk)
        except (OSError, http.client.HTTPException):
            pass  # the daemon stopped at the end of the run

    def poll(self) -> None:
        while not self.stop.wait(0.5):
            try:
                with urllib.request.urlopen("http://127.0.0.1:%d/api/v1/status" % self.port,
                                            timeout=30) as r:
                    r.read()
            except (OSError, http.client.HTTPException):
                if not self.stop.is_set():  # during the run: counted (poll_errors)
                    self.poll_errors += 1

    def close(self) -> None:
        self.stop.set()


class Run:
    """candp2d on `cfg` (default: config(cycle_ms, baud)), its Modbus and HTTP ports learnt from
    its ready line (bench/can_load.py runs its own configuration)."""

    def __init__(self, binary: str, cycle_ms: int, workdir: str, baud: int | None = None,
                 cfg: dict[str, Any] | None = None) -> None:
        self.path = os.path.join(workdir, "line.json")
        with open(self.path, "w") as f:
            json.dump(cfg or config(cycle_ms, baud), f)
        self.log_path = os.path.join(workdir, "candp2d.log")
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen([binary, "--config", self.path, "--log-level", "info"],
                                     stdout=self.log, stderr=subprocess.STDOUT)
        end = time.monotonic() + 60
        while True:
            if self.proc.poll() is not None:
                sys.exit("candp2d exited:\n" + open(self.log_path).read()[-3000:])
            m = re.search(r"ready: modbus [\d.]+:(\d+), http [\d.]+:(\d+)",
                          open(self.log_path).read())
            if m:
                self.modbus, self.http = int(m.group(1)), int(m.group(2))
                break
            if time.monotonic() > end:
                self.proc.kill()
                sys.exit("no ready line")
            time.sleep(0.05)

    def wait_data_exch(self, timeout: float = 60) -> None:
        end = time.monotonic() + timeout
        while not all(g["dp_state"] == "Data_Exch" for g in self.status()["gateways"]):
            if time.monotonic() > end:
                sys.exit("not every gateway reached Data_Exch")
            time.sleep(0.2)

    def status(self) -> dict[str, Any]:
        with urllib.request.urlopen("http://127.0.0.1:%d/api/v1/status" % self.http,
                                    timeout=30) as r:
            doc: dict[str, Any] = json.loads(r.read())
            return doc

    def cpu_ticks(self) -> int:
        with open("/proc/%d/stat" % self.proc.pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return int(fields[11]) + int(fields[12])  # utime + stime

    def memory_kb(self) -> tuple[int, int]:
        out: dict[str, int] = {}
        with open("/proc/%d/status" % self.proc.pid) as f:
            for line in f:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    out[line.split(":")[0]] = int(line.split()[1])
        return out.get("VmRSS", 0), out.get("VmHWM", 0)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()


def frames_sent(status: dict[str, Any]) -> int:
    return sum(g.get("counters", {}).get("tx_frames", 0) for g in status["gateways"])


class Measurement(TypedDict):
    """One run of measure(), in the order it is printed."""
    line: str
    cycle_ms: int
    bus_cycle_mean_us: float
    bus_cycle_max_us: float
    events_bytes: int
    poll_errors: int
    cycles_done: int
    cycles_due: int
    p99_us: float
    max_us: float
    cpu_pct: float
    rss_kb: int
    hwm_kb: int
    frames: int


# The figures the summary takes the median of.
SummaryKey = Literal["cycles_done", "cycles_due", "p99_us", "cpu_pct", "rss_kb", "hwm_kb",
                     "bus_cycle_mean_us", "bus_cycle_max_us"]


def measure(binary: str, cycle_ms: int, seconds: float, baud: int | None = None,
            observe: bool = False) -> Measurement:
    with tempfile.TemporaryDirectory(prefix="candp2-line-") as d:
        r = Run(binary, cycle_ms, d, baud)
        observer: Observer | None = None
        try:
            r.wait_data_exch()
            stop = threading.Event()

            def writer() -> None:
                mb = ModbusTcpClient("127.0.0.1", port=r.modbus, timeout=5)
                mb.connect()
                k = 0
                while not stop.is_set():
                    k += 1
                    for first in range(0, 4000, 120):
                        mb.write_registers(first, [(k * 31 + first + j) & 0xFFFF
                                                   for j in range(120)], slave=3)
                    stop.wait(0.1)
                mb.close()

            t = threading.Thread(target=writer, daemon=True)
            t.start()
            if observe:
                observer = Observer(r.http)
            time.sleep(1.0)
            s0, c0, t0 = r.status(), r.cpu_ticks(), time.monotonic()
            time.sleep(seconds)
            s1, c1, t1 = r.status(), r.cpu_ticks(), time.monotonic()
            stop.set()
            t.join(10)
            rss, hwm = r.memory_kb()
            due = (t1 - t0) * 1000.0 / cycle_ms
            lat = s1["cycle"]["lateness_us"]
            hz = os.sysconf("SC_CLK_TCK")
            line = s1.get("line", {}).get("bus_cycle_us", {})
            return {"line": str(baud or "ideal"), "cycle_ms": cycle_ms,
                    "bus_cycle_mean_us": line.get("mean", 0),
                    "bus_cycle_max_us": line.get("max", 0),
                    "events_bytes": observer.bytes if observer else 0,
                    "poll_errors": observer.poll_errors if observer else 0,
                    "cycles_done": s1["cycle"]["cycles"] - s0["cycle"]["cycles"],
                    "cycles_due": round(due), "p99_us": lat["p99"], "max_us": lat["max"],
                    "cpu_pct": round(100.0 * (c1 - c0) / hz / (t1 - t0), 1),
                    "rss_kb": rss, "hwm_kb": hwm, "frames": frames_sent(s1) - frames_sent(s0)}
        finally:
            if observer:
                observer.close()
            r.stop()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--a", required=True, help="candp2d binary A")
    ap.add_argument("--b", help="candp2d binary B (alternating with A)")
    ap.add_argument("--cycles", default="1,2,10")
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--lines", default="ideal",
                    help="comma-separated: ideal and/or baud rates (a line in time)")
    ap.add_argument("--observer", action="store_true", help="keep a panel open over each run")
    args = ap.parse_args()
    lines = [None if x == "ideal" else int(x) for x in args.lines.split(",")]
    binaries = [("A", args.a)] + ([("B", args.b)] if args.b else [])
    rows: list[tuple[str, Measurement]] = []  # (binary, its run)
    for cycle in [int(c) for c in args.cycles.split(",")]:
        for _ in range(args.rounds):
            for baud in lines:
                for name, binary in binaries:
                    row = measure(binary, cycle, args.seconds, baud, args.observer)
                    rows.append((name, row))
                    print(json.dumps({"binary": name, **row}), flush=True)
    print("summary (medians):")
    keys: tuple[SummaryKey, ...] = ("cycles_done", "cycles_due", "p99_us", "cpu_pct", "rss_kb",
                                    "hwm_kb", "bus_cycle_mean_us", "bus_cycle_max_us")
    for cycle in sorted({r["cycle_ms"] for _, r in rows}):
        for baud in lines:
            for name, _ in binaries:
                sel = [r for b, r in rows if r["cycle_ms"] == cycle and b == name
                       and r["line"] == str(baud or "ideal")]
                med = {k: statistics.median(r[k] for r in sel) for k in keys}
                print(json.dumps({"binary": name, "line": str(baud or "ideal"),
                                  "cycle_ms": cycle, **med}))


if __name__ == "__main__":
    main()
