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

Prints one JSON line per run and the medians with the ratios timed / ideal.

Usage: bench/can_load.py daemon --candp2d build/bin/candp2d [--seconds 10] [--rounds 2]
       bench/can_load.py replay --timed-bus-run build/tests/timed_bus_run [--virtual-s 60]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "e2e"))
from http_common import LINE_GATEWAYS, LINE_SLOTS, SLOT_LEN, line_slot_address  # noqa: E402

WRITE_REGISTERS = 560  # Q 0..1119: every output slot of line_slot_address
CYCLE_MS = 10


def config(bitrate):
    """122 gateways, two a bus; with `bitrate` the buses are timed."""
    gws, buses = [], {}
    for i in range(LINE_GATEWAYS):
        a = 3 + i
        bus = "can%d" % (i // 2)
        buses[bus] = {"type": "virtual", **({"bitrate": bitrate} if bitrate else {})}
        tx, rx = (0x100, 0x300) if i % 2 == 0 else (0x300, 0x100)
        slots = []
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


def counters(status):
    g = status["gateways"]
    return {"tx": sum(x.get("counters", {}).get("tx_frames", 0) for x in g),
            "rx": sum(x.get("counters", {}).get("rx_frames", 0) for x in g),
            "irq_lost": sum(x.get("counters", {}).get("irq_lost", 0) for x in g),
            "tx_lost": sum(b.get("tx_lost", 0) for b in status.get("buses", []))}


def measure_daemon(binary, bitrate, seconds):
    from line_load import Run  # noqa: E402  (pymodbus)
    from pymodbus.client import ModbusTcpClient  # noqa: E402
    with tempfile.TemporaryDirectory(prefix="candp2-can-") as d:
        r = Run(binary, CYCLE_MS, d, cfg=config(bitrate))
        try:
            r.wait_data_exch()
            stop, rounds = threading.Event(), [0]

            def writer():
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
            time.sleep(1.0)
            s0, c0, w0, t0 = counters(r.status()), r.cpu_ticks(), rounds[0], time.monotonic()
            time.sleep(seconds)
            s1, c1, w1, t1 = counters(r.status()), r.cpu_ticks(), rounds[0], time.monotonic()
            stop.set()
            t.join(10)
            hz = os.sysconf("SC_CLK_TCK")
            return {"bus": bitrate or "ideal",
                    "cpu_pct": round(100.0 * (c1 - c0) / hz / (t1 - t0), 1),
                    "writes_per_s": round((w1 - w0) / (t1 - t0), 1),
                    **{k: s1[k] - s0[k] for k in s1}}
        finally:
            r.stop()


def measure_replay(binary, bitrate, virtual_s):
    with tempfile.TemporaryDirectory(prefix="candp2-can-") as d:
        path = os.path.join(d, "can.json")
        with open(path, "w") as f:
            json.dump(config(bitrate), f)
        r = subprocess.run([binary, path, str(virtual_s), "--writer", "counter"],
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["daemon", "replay"])
    ap.add_argument("--candp2d")
    ap.add_argument("--timed-bus-run")
    ap.add_argument("--bitrate", default="1000k")
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--virtual-s", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    rows = []
    for _ in range(args.rounds):
        for bitrate in (args.bitrate, None):
            if args.mode == "daemon":
                row = measure_daemon(args.candp2d, bitrate, args.seconds)
            else:
                row = measure_replay(args.timed_bus_run, bitrate, args.virtual_s)
            rows.append(row)
            print(json.dumps(row), flush=True)
    keys = [k for k, v in rows[0].items() if isinstance(v, (int, float))]
    med = {}
    for bus in (args.bitrate, "ideal"):
        med[bus] = {k: statistics.median(r[k] for r in rows if r["bus"] == bus) for k in keys}
        print(json.dumps({"bus": bus, "median": med[bus]}))
    ratio = "cpu_pct" if args.mode == "daemon" else "speed"
    if med["ideal"][ratio]:
        print(json.dumps({"timed_over_ideal_" + ratio:
                          round(med[args.bitrate][ratio] / med["ideal"][ratio], 3)}))


if __name__ == "__main__":
    main()
