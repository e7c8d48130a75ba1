#!/usr/bin/python3
"""The HTTP face after connection bursts, A/B (docs/daemon.md "HTTP connections"):
each binary runs config/demo.json with its HTTP face on a free loopback port; 1000 connections are
opened and closed, ten times in a row, then one GET /api/v1/status must be answered. Builds from
before the HTTP face accepted its own connections never answered again (libmicrohttpd's listening
socket left its epoll set at the connection limit); tests/e2e/http_hostile_e2e.py asserts the same
on the current build.

Only the standard library and the daemon's own command line: it runs against any candp2d, old or
new (no READY=1 protocol needed; it polls the face until it answers before the bursts).

Usage: bench/http_burst.py --a OLD/candp2d --b build/bin/candp2d [--rounds 3]
"""

import argparse
import json
import os
import resource
import select
import socket
import subprocess
import tempfile
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def burst(port: int, n: int = 1000, deadline_s: float = 3.0) -> None:
    socks: list[socket.socket] = []
    for _ in range(n):
        s = socket.socket()
        s.setblocking(False)
        try:
            s.connect(("127.0.0.1", port))
        except BlockingIOError:
            pass
        socks.append(s)
    poll = select.poll()
    pending = {s.fileno() for s in socks}
    for fd in pending:
        poll.register(fd, select.POLLOUT)
    end = time.monotonic() + deadline_s
    while pending and time.monotonic() < end:
        for fd, _ in poll.poll(100):
            poll.unregister(fd)
            pending.discard(fd)
    for s in socks:
        s.close()


def one_run(binary: str, workdir: str, wait_s: float) -> float | None:
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        cfg = json.load(f)
    http = free_port()
    cfg["modbus"]["listen"] = "127.0.0.1:%d" % free_port()
    cfg["http"] = {"listen": "127.0.0.1:%d" % http}
    for bus in cfg.get("buses", {}).values():
        if "socketcand" in bus:
            bus["socketcand"] = "127.0.0.1:%d" % free_port()
    path = os.path.join(workdir, "config-%d.json" % http)
    with open(path, "w") as f:
        json.dump(cfg, f)
    url = "http://127.0.0.1:%d/api/v1/status" % http
    with open(path + ".log", "w") as log:
        proc = subprocess.Popen([binary, "--config", path], stdout=subprocess.DEVNULL, stderr=log)
    try:
        end = time.monotonic() + 10
        while True:
            try:
                urllib.request.urlopen(url, timeout=1).read()
                break
            except OSError:
                if time.monotonic() > end or proc.poll() is not None:
                    raise RuntimeError("%s did not start (log: %s)" % (binary, path + ".log"))
                time.sleep(0.05)
        for _ in range(10):
            burst(http)
        t = time.monotonic()
        try:
            urllib.request.urlopen(url, timeout=wait_s).read()
            return time.monotonic() - t
        except OSError:
            return None
    finally:
        proc.terminate()
        proc.wait(5)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a", required=True, help="candp2d A (e.g. the build before)")
    ap.add_argument("--b", required=True, help="candp2d B (e.g. build/bin/candp2d)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--wait", type=float, default=5.0, help="seconds to wait for the answer")
    args = ap.parse_args()
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(4096, hard), hard))
    with tempfile.TemporaryDirectory() as work:
        for r in range(args.rounds):
            for label, binary in (("A", args.a), ("B", args.b)):
                took = one_run(binary, work, args.wait)
                print("round %d %s: %s" % (r + 1, label, "answered in %.1f ms" % (took * 1000)
                                           if took is not None else
                                           "NOT answered within %.0f s" % args.wait))


if __name__ == "__main__":
    main()
