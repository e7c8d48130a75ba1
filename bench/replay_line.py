#!/usr/bin/python3
"""Replay of a line in time against the ideal line, A/B in one run (docs/profibus.md "The line
in time", "Performance").

A configuration of --stations CAN-DP/2 gateways (DP 3.., 2 output and 2 input slots of 6 bytes
each, every gateway on its own virtual bus) at a --cycle-ms master cycle is replayed for
--hours of virtual time (one expect_dp_state, then advance_ms), once on the ideal line and once
on a line in time at --baud, --rounds times alternating. Prints per run the wall time and the
speed (virtual seconds per wall second), and the medians; the ratio timed/ideal says what the
line's physics costs in replay.

Usage: bench/replay_line.py --candp2 build-release/bin/candp2 [--stations 32] [--baud 1500000]
       [--hours 1] [--cycle-ms 10] [--rounds 3]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time


def config(stations: int, cycle_ms: int, baud: int | None) -> dict[str, object]:
    gws: list[dict[str, object]] = []
    buses: dict[str, dict[str, str]] = {}
    for i in range(stations):
        a = 3 + i
        bus = "can%d" % a
        buses[bus] = {"type": "virtual"}
        slots: list[dict[str, object]] = []
        for k, (io, base) in enumerate((("output", 0x200), ("output", 0x300),
                                        ("input", 0x180), ("input", 0x280))):
            slots.append({"io": io, "address": (i * 12 + (k % 2) * 6) % 4000, "length": 6,
                          "comment": "%02X,%02X,00" % ((base + a) >> 8, (base + a) & 0xFF)})
        gws.append({"name": "gw%d" % a, "address": a, "bus": bus,
                    "parameters": {"can_bitrate": "500k"}, "slots": slots})
    master = {"address": 1, "cycle_ms": cycle_ms}
    if baud:
        master["baud"] = baud
    return {"modbus": {"listen": "127.0.0.1:0"}, "master": master, "buses": buses,
            "gateways": gws, "log": {"level": "warn"}}


def run(candp2: str, workdir: str, stations: int, cycle_ms: int, baud: int | None,
        hours: float) -> float:
    cfg = os.path.join(workdir, "line-%s.json" % (baud or "ideal"))
    with open(cfg, "w") as f:
        json.dump(config(stations, cycle_ms, baud), f)
    scenario = {"format": "candp2-replay", "version": 2, "name": "replay-line",
                "config": cfg,
                "steps": [{"expect_dp_state": "data_exch", "gateway": "gw3", "within_ms": 5000},
                          {"advance_ms": int(hours * 3600000)},
                          {"expect_dp_state": "data_exch", "gateway": "gw%d" % (2 + stations)}]}
    path = os.path.join(workdir, "scenario-%s.json" % (baud or "ideal"))
    with open(path, "w") as f:
        json.dump(scenario, f)
    t0 = time.monotonic()
    r = subprocess.run([candp2, "replay", "--quiet", path], capture_output=True, text=True)
    wall = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit("replay failed:\n" + r.stdout[-3000:] + r.stderr[-3000:])
    return wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2", required=True)
    ap.add_argument("--stations", type=int, default=32)
    ap.add_argument("--baud", type=int, default=1500000)
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--cycle-ms", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    walls: dict[str, list[float]] = {"ideal": [], "timed": []}
    with tempfile.TemporaryDirectory(prefix="candp2-replay-") as d:
        for _ in range(args.rounds):
            for name, baud in (("ideal", None), ("timed", args.baud)):
                w = run(args.candp2, d, args.stations, args.cycle_ms, baud, args.hours)
                walls[name].append(w)
                print(json.dumps({"line": name, "wall_s": round(w, 2),
                                  "speed": round(args.hours * 3600 / w)}), flush=True)
    med = {k: statistics.median(v) for k, v in walls.items()}
    print(json.dumps({"stations": args.stations, "baud": args.baud, "hours": args.hours,
                      "ideal_wall_s": round(med["ideal"], 2),
                      "timed_wall_s": round(med["timed"], 2),
                      "ideal_speed": round(args.hours * 3600 / med["ideal"]),
                      "timed_speed": round(args.hours * 3600 / med["timed"]),
                      "timed_vs_ideal": round(med["ideal"] / med["timed"], 2)}))


if __name__ == "__main__":
    main()
