#!/usr/bin/python3
"""candp2d under systemd's notify protocol and journal, with this test in systemd's place:
the test owns the NOTIFY_SOCKET (an AF_UNIX datagram socket, sd_notify(3)) and the JOURNAL_STREAM.

  1. READY=1 arrives only once Modbus accepts connections: the test connects the moment READY=1
     arrives (and must succeed), and every datagram before it must be free of READY=1;
  2. the first STATUS= says "1 gateway, ..."; after a Modbus client connects and the gateway
     reaches Data_Exch a new STATUS= says "1 gateway, 1 in Data_Exch, 1 Modbus client";
  3. WATCHDOG_USEC=300000 gives WATCHDOG=1 every ~150 ms (at least 4 within 2 s);
  4. SIGTERM gives STOPPING=1, then exit status 0;
  5. with JOURNAL_STREAM = stderr's st_dev:st_ino every log line is "<N>[component] ..." with
     syslog priorities (6 = info) and no time stamp;
  6. a start that fails (Modbus port taken) never sends READY=1, says why in STATUS= and exits 1;
     its stderr does not match JOURNAL_STREAM, so its lines keep their time stamps;
  7. NOTIFY_SOCKET in the abstract namespace ("@name") works as a path does, and a WATCHDOG_PID
     that is not candp2d's turns the watchdog off (sd_watchdog_enabled(3); candp2d speaks the
     protocol itself, docs/daemon.md "systemd").

  notify_test.py --candp2d build/bin/candp2d
"""

import argparse
import json
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TIMESTAMP = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} ")


def fail(msg):
    raise SystemExit("FAIL: " + msg)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def demo_config(tmp, modbus_port):
    """config/demo.json on free ports (like tests/e2e/demo_e2e.py)."""
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        cfg = json.load(f)
    cfg["modbus"]["listen"] = "127.0.0.1:%d" % modbus_port
    for bus in cfg["buses"].values():
        if "socketcand" in bus:
            bus["socketcand"] = "127.0.0.1:%d" % free_port()
    path = os.path.join(tmp, "candp2d-%d.json" % modbus_port)
    with open(path, "w") as f:
        json.dump(cfg, f)
    return path


class Notify:
    """The service manager's end of NOTIFY_SOCKET."""

    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        # "@name": the abstract namespace, as systemd writes it in NOTIFY_SOCKET.
        self.sock.bind("\0" + path[1:] if path.startswith("@") else path)
        self.path = path
        self.messages = []  # every datagram, in order: {"READY": "1", "STATUS": "..."}

    def receive(self, timeout):
        self.sock.settimeout(max(timeout, 0.001))
        try:
            data = self.sock.recv(4096)
        except socket.timeout:
            return None
        fields = dict(line.split("=", 1) for line in data.decode().splitlines() if "=" in line)
        self.messages.append(fields)
        return fields

    def wait_for(self, what, proc, timeout=10.0, may_exit=False):
        """The first datagram (after those already seen) for which what(fields) holds. Datagrams
        sent before an exit stay queued, so may_exit=True keeps reading after it."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if not may_exit and proc.poll() is not None:
                fail("candp2d exited with %s while waiting" % proc.returncode)
            m = self.receive(min(0.2, end - time.monotonic()))
            if m is not None and what(m):
                return m
        fail("timed out; datagrams so far: %s" % self.messages)

    def close(self):
        self.sock.close()


def start(candp2d, config, env_extra, stderr):
    env = {k: v for k, v in os.environ.items()
           if k not in ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID", "JOURNAL_STREAM")}
    env.update(env_extra)
    return subprocess.Popen([candp2d, "--config", config], stdout=subprocess.DEVNULL,
                            stderr=stderr, env=env)


def test_service(candp2d, tmp):
    port = free_port()
    config = demo_config(tmp, port)
    notify = Notify(os.path.join(tmp, "notify"))
    err_path = os.path.join(tmp, "stderr-journal")
    with open(err_path, "w") as err:
        st = os.fstat(err.fileno())
        proc = start(candp2d, config, {
            "NOTIFY_SOCKET": notify.path,
            "WATCHDOG_USEC": "300000",
            "JOURNAL_STREAM": "%d:%d" % (st.st_dev, st.st_ino),
        }, err)
    client = None
    try:
        # 1. READY=1 only when Modbus accepts: connect the moment it arrives.
        ready = notify.wait_for(lambda m: "READY" in m, proc)
        try:
            client = socket.create_connection(("127.0.0.1", port), timeout=1)
        except OSError as e:
            fail("READY=1 sent but Modbus port %d refuses: %s" % (port, e))
        before = notify.messages[:-1]
        if any("READY" in m for m in before):
            fail("READY=1 twice or early: %s" % notify.messages)
        if ready["READY"] != "1":
            fail("READY=%s" % ready["READY"])
        print("READY=1 with STATUS=%r; Modbus accepted at once" % ready.get("STATUS"))
        if not ready.get("STATUS", "").startswith("1 gateway, "):
            fail("first STATUS=%r" % ready.get("STATUS"))
        # The bound addresses in the same datagram (docs/daemon.md "systemd").
        if ready.get("X_CANDP2_MODBUS") != "127.0.0.1:%d" % port:
            fail("X_CANDP2_MODBUS=%r, expected 127.0.0.1:%d" % (ready.get("X_CANDP2_MODBUS"), port))
        if not re.fullmatch(r"can0=127\.0\.0\.1:\d+", ready.get("X_CANDP2_SOCKETCAND", "")):
            fail("X_CANDP2_SOCKETCAND=%r" % ready.get("X_CANDP2_SOCKETCAND"))

        # 2. STATUS= follows the gateway (Data_Exch) and the client we hold open.
        want = "1 gateway, 1 in Data_Exch, 1 Modbus client"
        notify.wait_for(lambda m: m.get("STATUS") == want, proc, timeout=10)
        print("STATUS=%s" % want)

        # 3. WATCHDOG=1 at half of WATCHDOG_USEC (150 ms): at least 4 in 2 s.
        seen = len([m for m in notify.messages if m.get("WATCHDOG") == "1"])
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            notify.receive(end - time.monotonic())
        dogs = len([m for m in notify.messages if m.get("WATCHDOG") == "1"]) - seen
        if dogs < 4 or dogs > 20:
            fail("%d WATCHDOG=1 in 2 s with WATCHDOG_USEC=300000 (expected ~13)" % dogs)
        print("WATCHDOG=1: %d in 2 s" % dogs)

        # 4. SIGTERM: STOPPING=1, then exit 0.
        proc.send_signal(signal.SIGTERM)
        notify.wait_for(lambda m: m.get("STOPPING") == "1", proc, may_exit=True)
        rc = proc.wait(timeout=10)
        if rc != 0:
            fail("exit status %d after SIGTERM" % rc)
        print("STOPPING=1, exit 0")
    finally:
        if client:
            client.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        notify.close()

    # 5. Journal format: "<N>[component] message", no time stamps.
    with open(err_path) as f:
        lines = f.read().splitlines()
    if not lines:
        fail("no log lines")
    bad = [l for l in lines if not re.match(r"^<[0-7]>\[[^\]]+\] ", l) or TIMESTAMP.match(l)]
    if bad:
        fail("lines not in journald format: %s" % bad[:5])
    if not any(re.match(r"^<6>\[candp2d\] ready: modbus 127\.0\.0\.1:%d" % port, l) for l in lines):
        fail("no \"<6>[candp2d] ready\" line: %s" % lines[:10])
    if not any(l == "<6>[candp2d] stopped" for l in lines):
        fail("no \"<6>[candp2d] stopped\" line")
    print("journal format: %d lines, e.g. %r" % (len(lines), lines[0]))


def test_failed_start(candp2d, tmp):
    # 6. The Modbus port is taken: no READY=1, STATUS= says why, exit 1.
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        config = demo_config(tmp, port)
        notify = Notify(os.path.join(tmp, "notify-fail"))
        err_path = os.path.join(tmp, "stderr-plain")
        try:
            with open(err_path, "w") as err:
                proc = start(candp2d, config, {"NOTIFY_SOCKET": notify.path,
                                               "JOURNAL_STREAM": "1:1"}, err)
            try:
                rc = proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                fail("candp2d kept running with its Modbus port taken")
            while notify.receive(0.05) is not None:
                pass
        finally:
            notify.close()
    if rc != 1:
        fail("exit status %d with the port taken (expected 1)" % rc)
    if any("READY" in m for m in notify.messages):
        fail("READY=1 although the start failed: %s" % notify.messages)
    if not any(m.get("STATUS", "").startswith("cannot start: ") for m in notify.messages):
        fail("no STATUS=cannot start: ...: %s" % notify.messages)
    with open(err_path) as f:
        lines = f.read().splitlines()
    if not lines or not all(TIMESTAMP.match(l) for l in lines):
        fail("JOURNAL_STREAM not matching stderr must keep time stamps: %s" % lines[:5])
    print("failed start: exit 1, no READY, %r" % notify.messages[-1].get("STATUS"))


def test_abstract_socket_foreign_watchdog(candp2d, tmp):
    # 7. "@name" socket; WATCHDOG_PID of another process: READY=1, no WATCHDOG=1, STOPPING=1.
    port = free_port()
    config = demo_config(tmp, port)
    notify = Notify("@candp2-notify-test-%d-%d" % (os.getpid(), port))
    proc = start(candp2d, config, {"NOTIFY_SOCKET": notify.path, "WATCHDOG_USEC": "100000",
                                   "WATCHDOG_PID": "1"}, subprocess.DEVNULL)
    try:
        notify.wait_for(lambda m: m.get("READY") == "1", proc)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            notify.receive(end - time.monotonic())
        if any("WATCHDOG" in m for m in notify.messages):
            fail("WATCHDOG=1 although WATCHDOG_PID names another process: %s" % notify.messages)
        proc.send_signal(signal.SIGTERM)
        notify.wait_for(lambda m: m.get("STOPPING") == "1", proc, may_exit=True)
        if proc.wait(timeout=10) != 0:
            fail("exit status %d after SIGTERM" % proc.returncode)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        notify.close()
    print("abstract NOTIFY_SOCKET %s: READY=1, STOPPING=1; foreign WATCHDOG_PID: no WATCHDOG=1"
          % notify.path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="candp2-notify-") as tmp:
        test_service(args.candp2d, tmp)
        test_failed_start(args.candp2d, tmp)
        test_abstract_socket_foreign_watchdog(args.candp2d, tmp)
    print("3 passed, 0 failed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
