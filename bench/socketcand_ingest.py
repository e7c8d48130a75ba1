#!/usr/bin/python3
"""How fast candp2d takes CAN frames from a socketcand client onto an ideal virtual bus, and
whether it loses any (docs/can-bus.md "Performance"), A/B in one run.

candp2d runs one gateway on an ideal virtual bus `can0` exported over socketcand. One raw-mode
client sends --frames frames (identifier 0x289, the gateway's Rx slot, 6 bytes each) as fast as
TCP takes them; the run ends when the bus has counted them all (GET /api/v1/status
buses[0].frames) or --timeout seconds passed. Per run: the frames the bus counted, the frames the
gateway received (its Rx counter, the slot's identifier), lost = sent - counted, and the rate
(frames counted per second from the first send to the last count).

The gateway's own frames are not the client's: its Tx slot sends once when the master's first
Data_Exchange reaches it (about 50 ms after the daemon answers). The run starts when the gateway
exchanges data, and the bus's count is taken less the gateway's Tx counter (a start before that
frame once counted 2 000 001 of 2 000 000).

Usage: bench/socketcand_ingest.py --a build/bin/candp2d [--b OTHER/candp2d] [--frames 2000000]
       [--rounds 3]
"""

import argparse
import json
import os
import socket
import statistics
import subprocess
import tempfile
import time
import urllib.request
from typing import Any, NotRequired, TypedDict


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def expect(sock: socket.socket, want: bytes, buf: bytes = b"") -> bytes:
    deadline = time.monotonic() + 5
    while want not in buf:
        if time.monotonic() > deadline:
            raise RuntimeError("socketcand: no %r (got %r)" % (want, buf))
        buf += sock.recv(4096)
    return buf[buf.index(want) + len(want):]


def status(http: int) -> dict[str, Any]:
    with urllib.request.urlopen("http://127.0.0.1:%d/api/v1/status" % http, timeout=10) as r:
        doc: dict[str, Any] = json.load(r)
        return doc


def counts(http: int) -> tuple[int, int | None]:
    """The frames on the bus that the gateway did not send, and its Rx counter (None: not in the
    status)."""
    st = status(http)
    bus = st["buses"][0]
    gw = st["gateways"][0]
    c = gw.get("counters", {})
    return bus["frames"] - c.get("tx_frames", 0), gw.get("rx_frames", c.get("rx_frames"))


def exchanging(http: int) -> bool:
    """The gateway is in Data_Exchange and has sent its Tx slot's first frame."""
    gw = status(http)["gateways"][0]
    return bool(gw.get("dp_state") == "Data_Exch" and gw.get("counters", {}).get("tx_frames"))


class Result(TypedDict):
    """One run, in the order it is printed."""
    sent: int
    counted: int
    gateway_rx: int
    lost: int
    send_s: float
    frames_per_s: int
    binary: NotRequired[str]  # set by main()


def one_run(candp2d: str, frames: int, timeout: float) -> Result:
    tmp = tempfile.mkdtemp(prefix="ingest-")
    modbus, scand, http = free_port(), free_port(), free_port()
    cfg = {"modbus": {"listen": "127.0.0.1:%d" % modbus},
           "http": {"listen": "127.0.0.1:%d" % http},
           "master": {"address": 1, "cycle_ms": 10},
           "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:%d" % scand}},
           "gateways": [{"name": "gw5", "address": 5, "bus": "can0", "slots": [
               {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
               {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}]}],
           "log": {"level": "warn"}}
    path = os.path.join(tmp, "candp2d.json")
    with open(path, "w") as f:
        json.dump(cfg, f)
    proc = subprocess.Popen([candp2d, "--config", path], stdout=subprocess.DEVNULL,
                            stderr=open(os.path.join(tmp, "log"), "w"))
    try:
        deadline = time.monotonic() + 10
        while True:
            try:
                if exchanging(http):
                    break
            except OSError:
                pass
            if time.monotonic() > deadline or proc.poll() is not None:
                raise RuntimeError("candp2d did not answer, or its gateway did not exchange data")
            time.sleep(0.05)
        sock = socket.create_connection(("127.0.0.1", scand), timeout=5)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        rest = expect(sock, b"< hi >")
        sock.sendall(b"< open can0 >")
        rest = expect(sock, b"< ok >", rest)
        sock.sendall(b"< rawmode >")
        expect(sock, b"< ok >", rest)
        before, rx_before = counts(http)
        chunk = b"".join(b"< send 289 6 %02X 01 02 03 04 05 >" % (i & 0xFF) for i in range(1000))
        t0 = time.monotonic()
        for _ in range(frames // 1000):
            sock.sendall(chunk)
        sent = (frames // 1000) * 1000
        t_sent = time.monotonic()
        end = time.monotonic() + timeout
        counted = rx = 0
        while time.monotonic() < end:
            c, r = counts(http)
            counted, rx = c - before, (r or 0) - (rx_before or 0)
            if counted >= sent:
                break
            time.sleep(0.02)
        t1 = time.monotonic()
        sock.close()
        return {"sent": sent, "counted": counted, "gateway_rx": rx, "lost": sent - counted,
                "send_s": round(t_sent - t0, 3), "frames_per_s": round(counted / (t1 - t0))}
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a", required=True)
    ap.add_argument("--b")
    ap.add_argument("--frames", type=int, default=2000000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=60)
    args = ap.parse_args()
    bins = [("A", args.a)] + ([("B", args.b)] if args.b else [])
    results: dict[str, list[Result]] = {name: [] for name, _ in bins}
    for _ in range(args.rounds):
        for name, path in bins:
            r = one_run(path, args.frames, args.timeout)
            r["binary"] = name
            print(json.dumps(r), flush=True)
            results[name].append(r)
    for name, rs in results.items():
        print("%s: median %.0f frames/s, lost %s" % (
            name, statistics.median(r["frames_per_s"] for r in rs), [r["lost"] for r in rs]))


if __name__ == "__main__":
    main()
