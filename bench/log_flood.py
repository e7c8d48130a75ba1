#!/usr/bin/python3
"""How many log lines hostile Modbus clients make (docs/daemon.md "Logging"): CLIENTS clients
connect to candp2d (the demo) and send garbage, each dropped and reconnecting at once, for
SECONDS; meanwhile one well-behaved client polls the status block and counts its errors. Prints
the daemon's log lines (and warnings) over the run and the polling client's errors.

  PYTHONPATH=python bench/log_flood.py --candp2d build/bin/candp2d [--clients 40] [--seconds 20]

Run it against two builds side by side for an A/B.
"""

import argparse
import socket
import struct
import threading
import time

# python/ is on PYTHONPATH at run time only: mypy run from bench/ sees candp2 as Any.
import candp2


def garbage(address: tuple[str, int], stop: threading.Event, sent: list[int]) -> None:
    while not stop.is_set():
        try:
            with socket.create_connection(address, timeout=2) as s:
                s.sendall(b"GET / HTTP/1.0\r\n\r\n")
                s.recv(16)
                sent[0] += 1
        except OSError:
            time.sleep(0.001)


def poll(address: tuple[str, int], stop: threading.Event, result: dict[str, int]) -> None:
    request = struct.pack(">HHHBBHH", 1, 0, 6, 3, 4, 8192, 1)
    with socket.create_connection(address, timeout=2) as s:
        while not stop.is_set():
            try:
                s.sendall(request)
                answer = s.recv(64)
                result["ok" if len(answer) >= 9 and answer[7] == 4 else "errors"] += 1
            except OSError:
                result["errors"] += 1
                return
            time.sleep(0.01)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--clients", type=int, default=40)
    ap.add_argument("--seconds", type=float, default=20)
    args = ap.parse_args()
    config = candp2.example("demo.json")
    with candp2.Daemon(config, binary=args.candp2d) as daemon:
        address = daemon.modbus_address
        before = len(daemon.log.splitlines())
        stop = threading.Event()
        sent = [[0] for _ in range(args.clients)]
        result = {"ok": 0, "errors": 0}
        threads = [threading.Thread(target=garbage, args=(address, stop, sent[i]))
                   for i in range(args.clients)]
        threads.append(threading.Thread(target=poll, args=(address, stop, result)))
        for t in threads:
            t.start()
        time.sleep(args.seconds)
        stop.set()
        for t in threads:
            t.join(timeout=10)
        time.sleep(1.5)  # the last summaries
        lines = daemon.log.splitlines()[before:]
        warnings = [line for line in lines if " warn " in line or "warning" in line]
        print("%d garbage connections in %.0f s from %d clients: %d log lines (%d warnings); "
              "polling client: %d answers, %d errors"
              % (sum(s[0] for s in sent), args.seconds, args.clients, len(lines), len(warnings),
                 result["ok"], result["errors"]))


if __name__ == "__main__":
    main()
