#!/usr/bin/python3
"""CAN buses in time against ideal buses on the largest line, A/B in one run (docs/can-bus.md
"Performance").

122 gateways (DP addresses 3..124) x 48 six-byte slots (24 outputs, 24 inputs) at a 10 ms master
cycle, two gateways on each of 61 virtual buses: the Tx identifiers of one (0x100 + k) are the Rx
identifiers of the other, and the other way round (0x300 + k). Every output is rewritten every
master cycle, so each bus is offered 2 x 24 frames every 10 ms (4800 frames/s, about 540 kbit/s
at the frames' exact lengths). The buses are timed at --bitrate (default "1000k") or ideal.

  daemon   candp2d, timed and ideal alternately --rounds times, --seconds each: a Modbus client
           rewrites Q 0..1111 (every output slot of every gateway: the slots share the image,
           tests/e2e/http_common.line_slot_address) every 10 ms; candp2d's CPU (utime + stime),
           the frames the gateways sent and received, the frames lost (the gateways' IRQ_LOST
           and the timed buses' tx_lost), the Modbus rounds written
  replay   tests' timed_bus_run (the plant in virtual time, as replay runs it; its writer changes
           every output between two Data_Exchanges) for --virtual-s of virtual time, timed and
           ideal alternately: the wall time and the speed (virtual s per wall s)

options of both:
  --paired     the timed and the ideal run side by side (one on each core) instead of one after
               the other: the shared VM's speed drifts by tens of per cent from minute to minute,
               and a ratio of two runs minutes apart measures the drift (docs/can-bus.md
               "Performance"); the timed row has the ratio of that pair
replay options:
  --step-us N  the plant's step (timed_bus_run --step-us; replay's 0 by default, candp2d's 1000:
               the daemon's share of the work in virtual time)
daemon options:
  --observer   over each run an open panel (the overview's event stream and a gateway panel's,
               /api/v1/events?gw=3, read continuously; GET /api/v1/status twice a second) and
               hostile HTTP clients beside it (every half second a burst of 200 connections
               opened and closed; 20 idle connections held; one header trickled a byte every
               100 ms): the row counts the events' bytes, failed polls and hostile connections
  --stall-ms N candp2d stopped (SIGSTOP) for N ms once in the middle of the run: the row has the
               host stalls candp2d counted (docs/daemon.md "Host stalls")
  --against B  two builds on the same buses side by side instead (A = --candp2d, B = this one;
               --bitrate, or "ideal"), one on each core, which starts first alternating: each
               round's B / A of the CPU, and their median (a change's cost where a ratio of two
               runs minutes apart would measure the VM's drift); with --observer both
               have their observers
Each daemon row also has what was lost: irq_lost, tx_lost, rx_short (frames sent that the other
gateway did not take: on these buses every frame sent is an Rx slot of the other gateway), the
master cycles run against those due (between the middles of the two status requests; status_ms
the longer request) and the cycle lateness (p99, max).

Prints one JSON line per run and the medians with the ratios timed / ideal.

Usage: bench/can_load.py daemon --candp2d build/bin/candp2d [--seconds 10] [--rounds 2]
           [--paired] [--observer] [--stall-ms 300]
       bench/can_load.py daemon --candp2d A/candp2d --against B/candp2d [--bitrate ideal]
       bench/can_load.py replay --timed-bus-run build/tests/timed_bus_run [--virtual-s 60]
           [--paired] [--step-us 1000]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "e2e"))
# tests/e2e is on sys.path at run time only, and untyped: mypy sees its names as Any.
from http_common import (  # type: ignore[import]  # noqa: E402
    LINE_GATEWAYS, LINE_SLOTS, SLOT_LEN, line_slot_address)

if TYPE_CHECKING:  # imported where used: replay needs neither pymodbus nor line_load
    from line_load import Observer

# A row printed: figures by name, which depend on the mode and the options.
Row = dict[str, Any]

WRITE_REGISTERS = 560  # Q 0..1119: every output slot of line_slot_address
CYCLE_MS = 10


def config(bitrate: str | None) -> dict[str, object]:
    """122 gateways, two a bus; with `bitrate` the buses are timed."""
    gws: list[dict[str, object]] = []
    buses: dict[str, dict[str, str]] = {}
    for i in range(LINE_GATEWAYS):
        a = 3 + i
        bus = "can%d" % (i // 2)
        buses[bus] = {"type": "virtual", **({"bitrate": bitrate} if bitrate else {})}
        tx, rx = (0x100, 0x300) if i % 2 == 0 else (0x300, 0x100)
        slots: list[dict[str, object]] = []
        for io, base in (("output", tx), ("input", rx)):
            for k in range(LINE_SLOTS):
                ident = base + k
                slots.append({"io": io, "address": line_slot_address(a, k), "length": SLOT_LEN,
                              "comment": "%02X,%02X,00" % (ident >> 8, ident & 0xFF)})
        gws.append({"name": "gw%d" % a, "address": a, "bus": bus,
                    "parameters": {"can_bitrate": bitrate or "1000k"}, "slots": slots})
    return {"modbus": {"listen": "127.0.0.1:0"}, "http": {"listen": "127.0.0.1:0"},
            "master": {"address": 1, "cycle_ms": CYCLE_MS}, "buses": buses, "gateways": gws,
            "log": {"level": "warn"}}


def counters(status: dict[str, Any]) -> dict[str, int]:
    g = status["gateways"]
    return {"tx": sum(x.get("counters", {}).get("tx_frames", 0) for x in g),
            "rx": sum(x.get("counters", {}).get("rx_frames", 0) for x in g),
            "irq_lost": sum(x.get("counters", {}).get("irq_lost", 0) for x in g),
            "tx_lost": sum(b.get("tx_lost", 0) for b in status.get("buses", []))}


class Hostile:
    """HTTP clients a panel's host may have beside it: bursts of connections opened and closed,
    idle connections held, a header trickled a byte at a time (tests/e2e/http_hostile_e2e.py
    asserts what the daemon does with each)."""

    def __init__(self, http_port: int) -> None:
        self.port, self.conns, self.stop = http_port, 0, threading.Event()
        self.threads = [threading.Thread(target=self.bursts, daemon=True),
                        threading.Thread(target=self.trickle, daemon=True)]
        self.idle: list[socket.socket] = []
        for _ in range(20):
            self.idle.append(socket.create_connection(("127.0.0.1", http_port), timeout=5))
            self.conns += 1
        for t in self.threads:
            t.start()

    def bursts(self) -> None:
        from http_burst import burst  # noqa: E402
        while not self.stop.wait(0.5):
            burst(self.port, n=200, deadline_s=1.0)
            self.conns += 200

    def trickle(self) -> None:
        while not self.stop.is_set():
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=5) as c:
                    self.conns += 1
                    for ch in b"GET /api/v1/status HTTP/1.1\r\nX-Slow: " + b"a" * 10000:
                        if self.stop.wait(0.1):
                            return
                        c.send(bytes([ch]))
            except OSError:
                pass  # cut by the daemon (its idle timeout): open the next one

    def close(self) -> None:
        self.stop.set()
        for c in self.idle:
            c.close()


def watchers(http_port: int) -> tuple[Observer, Observer, Hostile]:
    """An open panel (line_load.Observer: the overview's stream, the status twice a second), a
    gateway panel's stream, and the hostile clients."""
    from line_load import Observer  # noqa: E402
    return (Observer(http_port), Observer(http_port, "/api/v1/events?gw=3", poll=False),
            Hostile(http_port))


def measure_daemon(binary: str, bitrate: str | None, seconds: float, observe: bool = False,
                   stall_ms: int = 0) -> Row:
    from line_load import Run  # noqa: E402  (pymodbus)
    from pymodbus.client import ModbusTcpClient  # noqa: E402
    with tempfile.TemporaryDirectory(prefix="candp2-can-") as d:
        r = Run(binary, CYCLE_MS, d, cfg=config(bitrate))
        seen: tuple[Observer, Observer, Hostile] | None = None
        try:
            r.wait_data_exch()
            stop, rounds = threading.Event(), [0]

            def writer() -> None:
                mb = ModbusTcpClient("127.0.0.1", port=r.modbus, timeout=5)
                mb.connect()
                nxt = time.monotonic()
                while not stop.is_set():
                    k = rounds[0] = rounds[0] + 1
                    for first in range(0, WRITE_REGISTERS, 120):
                        mb.write_registers(first, [(k * 31 + first + j) & 0xFFFF
                                                   for j in range(120)], slave=3)
                    nxt += CYCLE_MS / 1000.0
                    stop.wait(max(0.0, nxt - time.monotonic()))
                mb.close()

            t = threading.Thread(target=writer, daemon=True)
            t.start()
            if observe:
                seen = watchers(r.http)
            time.sleep(1.0)
            # A status is the daemon's state at some moment of its request: the cycles due are
            # counted between the middles of the two requests (with observers attached the first
            # may wait a hundred ms behind their connections), and the row says the longest wait.
            a0 = time.monotonic()
            st0 = r.status()
            s0, c0, w0, t0 = counters(st0), r.cpu_ticks(), rounds[0], time.monotonic()
            if stall_ms:
                time.sleep(seconds / 2)
                os.kill(r.proc.pid, signal.SIGSTOP)
                time.sleep(stall_ms / 1000.0)
                os.kill(r.proc.pid, signal.SIGCONT)
                time.sleep(seconds / 2)
            else:
                time.sleep(seconds)
            a1 = time.monotonic()
            st1 = r.status()
            s1, c1, w1, t1 = counters(st1), r.cpu_ticks(), rounds[0], time.monotonic()
            between_ms = ((t1 + a1) - (t0 + a0)) * 500.0
            stop.set()
            t.join(10)
            hz = os.sysconf("SC_CLK_TCK")
            row: Row = {"bus": bitrate or "ideal",
                        "cpu_pct": round(100.0 * (c1 - c0) / hz / (t1 - t0), 1),
                        "writes_per_s": round((w1 - w0) / (t1 - t0), 1),
                        **{k: s1[k] - s0[k] for k in s1}}
            lat, stalled = st1["cycle"]["lateness_us"], (st1["host_stalls"]["total_ms"]
                                                         - st0["host_stalls"]["total_ms"])
            # The simulated world pauses with the host (docs/daemon.md "Host stalls"): the cycles
            # due are those of the wall time less the stalls.
            row.update({"rx_short": row["tx"] - row["rx"],
                        "cycles_done": st1["cycle"]["cycles"] - st0["cycle"]["cycles"],
                        "cycles_due": round((between_ms - stalled) / CYCLE_MS),
                        "status_ms": round(1000.0 * max(t0 - a0, t1 - a1)),
                        "p99_us": lat["p99"], "max_us": lat["max"],
                        "stalls": st1["host_stalls"]["count"] - st0["host_stalls"]["count"],
                        "stall_ms": round(stalled, 1)})
            if seen:
                panel, gw, hostile = seen
                row.update({"events_bytes": panel.bytes + gw.bytes,
                            "poll_errors": panel.poll_errors, "hostile_conns": hostile.conns})
            return row
        finally:
            watching: tuple[Observer | Hostile, ...] = seen or ()
            for watcher in watching:
                watcher.close()
            r.stop()


def measure_replay(binary: str, bitrate: str | None, virtual_s: int, step_us: int = 0) -> Row:
    with tempfile.TemporaryDirectory(prefix="candp2-can-") as d:
        path = os.path.join(d, "can.json")
        with open(path, "w") as f:
            json.dump(config(bitrate), f)
        r = subprocess.run([binary, path, str(virtual_s), "--writer", "counter",
                            "--step-us", str(step_us)],
                           capture_output=True, text=True, timeout=24 * 3600)
        if r.returncode != 0:
            sys.exit(r.stderr)
        wall = float(r.stderr.split()[-4])  # "... S s wall time"
        buses = json.loads(r.stdout.splitlines()[-1])["buses"]
        return {"bus": bitrate or "ideal", "virtual_s": virtual_s, "wall_s": round(wall, 2),
                "speed": round(virtual_s / wall, 2),
                "frames": sum(b.get("frames", b.get("frames_sent", 0)) for b in buses.values()),
                "lost": sum(b.get("lost", 0) for b in buses.values()),
                "load_max_pct": round(max((b.get("load_max_pct", 0) for b in buses.values()),
                                          default=0), 2)}


def side_by_side(jobs: list[Callable[[], Row]], reverse: bool = False) -> list[Row]:
    """The jobs at once, one thread each (one daemon or replay per core), started in order or
    `reverse`d; their rows in the jobs' order."""
    out: list[Row | None] = [None] * len(jobs)

    def one(i: int) -> None:
        out[i] = jobs[i]()

    runs = [threading.Thread(target=one, args=(i,)) for i in range(len(jobs))]
    for t in reversed(runs) if reverse else runs:
        t.start()
    for t in runs:
        t.join()
    return [row for row in out if row is not None]


def against(a: str, b: str, bitrate: str | None, seconds: float, rounds: int,
            observe: bool = False) -> None:
    """--against: the builds A and B on the same buses side by side, B / A of the CPU."""
    ratios: list[float] = []
    for r in range(rounds):
        row_a, row_b = side_by_side([lambda: measure_daemon(a, bitrate, seconds, observe),
                                     lambda: measure_daemon(b, bitrate, seconds, observe)],
                                    reverse=r % 2 == 1)  # which one starts first alternates
        ratios.append(row_b["cpu_pct"] / max(row_a["cpu_pct"], 0.1))
        for build, row in (("A", row_a), ("B", row_b)):
            print(json.dumps({"build": build, **row}), flush=True)
        print(json.dumps({"round": r + 1, "b_over_a_cpu": round(ratios[-1], 3)}), flush=True)
    print(json.dumps({"bus": bitrate or "ideal",
                      "median_b_over_a_cpu": round(statistics.median(ratios), 3)}))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["daemon", "replay"])
    ap.add_argument("--candp2d")
    ap.add_argument("--timed-bus-run")
    ap.add_argument("--bitrate", default="1000k")
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--virtual-s", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--paired", action="store_true")
    ap.add_argument("--observer", action="store_true")
    ap.add_argument("--stall-ms", type=int, default=0)
    ap.add_argument("--step-us", type=int, default=0)
    ap.add_argument("--against")
    args = ap.parse_args()
    if args.against:
        bitrate = None if args.bitrate == "ideal" else args.bitrate
        against(args.candp2d, args.against, bitrate, args.seconds, args.rounds, args.observer)
        return
    rows: list[Row] = []
    for _ in range(args.rounds):
        if args.paired:
            def one(bitrate: str | None) -> Row:
                if args.mode == "daemon":
                    return measure_daemon(args.candp2d, bitrate, args.seconds, args.observer,
                                          args.stall_ms)
                return measure_replay(args.timed_bus_run, bitrate, args.virtual_s, args.step_us)

            batch = side_by_side([lambda: one(args.bitrate), lambda: one(None)])
            if args.mode == "daemon":
                batch[0]["ratio"] = round(batch[0]["cpu_pct"] / max(batch[1]["cpu_pct"], 0.1), 2)
            else:
                batch[0]["ratio"] = round(batch[0]["speed"] / max(batch[1]["speed"], 0.01), 3)
        elif args.mode == "daemon":
            batch = [measure_daemon(args.candp2d, b, args.seconds, args.observer, args.stall_ms)
                     for b in (args.bitrate, None)]
        else:
            batch = [measure_replay(args.timed_bus_run, b, args.virtual_s, args.step_us)
                     for b in (args.bitrate, None)]
        for row in batch:
            rows.append(row)
            print(json.dumps(row), flush=True)
    keys = [k for k, v in rows[-1].items() if isinstance(v, (int, float))]
    med: dict[str, dict[str, float]] = {}
    for bus in (args.bitrate, "ideal"):
        med[bus] = {k: statistics.median(r[k] for r in rows if r["bus"] == bus) for k in keys}
        print(json.dumps({"bus": bus, "median": med[bus]}))
    ratio = "cpu_pct" if args.mode == "daemon" else "speed"
    if med["ideal"][ratio]:
        print(json.dumps({"timed_over_ideal_" + ratio:
                          round(med[args.bitrate][ratio] / med["ideal"][ratio], 3)}))


if __name__ == "__main__":
    main()
