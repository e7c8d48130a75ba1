"""The HTTP face under hostile clients (docs/daemon.md "HTTP connections"), pytest on the
candp2 package (ctest e2e_http_hostile):

  - 1000 connections opened and closed, ten times in a row, then a request is answered within
    1 s (before the fix the face never answered again: libmicrohttpd took its listening socket
    out of its epoll set at its connection limit and put it back only in a later MHD_run, which
    never came once the last connections had closed);
  - 1000 idle connections held while a new client is served within 1 s, with http.max_clients
    above 1000 (the daemon holds them all) and at the default 64 (the ones waiting longest are
    evicted);
  - 50 clients sending a header byte a second: cut after http.idle_timeout_s, never answered,
    while other requests are answered within 1 s;
  - a 200 kB header refused (431) without harm.

Throughout, a Modbus client reads the status block every 20 ms: every read is answered (the slowest
within 500 ms), the DP master keeps cycling (Data_Exchanges at >= 90 % of the cycle rate) and
missed cycles stay below 5 % of the grid points; a cycle is due in the time the simulated world
ran, the wall time less the host stalls the daemon counted (docs/daemon.md "Host stalls": beyond
master.host_stall_ms the simulated world pauses with a stalled host). The bounds are far from what
a disturbed cycle looks like (a third of the cycles lost while one browser watched, before the face
was reworked) and far enough from a loaded CI machine's scheduling noise (9 of 743 seen with three
browsers beside); the numbers are printed, and bench/http_load.py measures the real margin. Every
wait has a deadline; the process's descriptor limit is raised for the sockets.
"""

import errno
import json
import os
import resource
import select
import socket
import sys
import threading
import time
import urllib.request

import pytest
from pymodbus.client import ModbusTcpClient  # python3-pymodbus

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from http_common import Daemon, demo_config, line_config  # noqa: E402

UNIT = 3
IDLE_TIMEOUT_S = 3


def raise_descriptor_limit(want=4096):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < want:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(want, hard), hard))
    return resource.getrlimit(resource.RLIMIT_NOFILE)[0]


def config(**http):
    """config/demo.json; with CANDP2_HOSTILE_LINE_BAUD set (a measurement, not CI) the largest
    line the product allows, 122 gateways x 48 slots at a 50 ms cycle on a line in time at that
    baud rate (docs/profibus.md "The line in time")."""
    baud = os.environ.get("CANDP2_HOSTILE_LINE_BAUD")
    if baud:
        cfg = line_config(50)
        cfg["master"]["baud"] = int(baud)
    else:
        cfg = demo_config()
    cfg.setdefault("http", {}).update(http)
    return cfg


CYCLE_S = config()["master"]["cycle_ms"] / 1000.0


class Watch(threading.Thread):
    """Reads the status block over Modbus every 20 ms: latencies, Data_Exchanges, missed
    cycles (register numbers from the daemon's own map)."""

    def __init__(self, daemon):
        super().__init__(daemon=True)
        self.daemon = daemon
        m = daemon.register_map
        self.block = m.status
        self.dx = m.fields["data_exchanges"].register
        self.missed = m.fields["master_cycles_missed"].register
        self.port = daemon.modbus_port
        self.stop_flag = threading.Event()
        self.latencies, self.samples, self.errors = [], [], []

    def stalled_s(self):
        """The host stalls' time so far (docs/daemon.md "Host stalls"): while candp2d was held
        back beyond master.host_stall_ms its simulated world paused, so no cycle was due then."""
        return self.daemon.status()["host_stalls"]["total_ms"] / 1000.0

    def run(self):
        self.stalled0 = self.stalled_s()
        mb = ModbusTcpClient("127.0.0.1", port=self.port, timeout=2)
        mb.connect()
        while not self.stop_flag.is_set():
            t = time.monotonic()
            r = mb.read_input_registers(self.block.first, self.block.count, slave=UNIT)
            dt = time.monotonic() - t
            if r.isError():
                self.errors.append(str(r))
            else:
                self.latencies.append(dt)
                self.samples.append((t, self.word(r.registers, self.dx),
                                     self.word(r.registers, self.missed)))
            self.stop_flag.wait(0.02)
        mb.close()

    def word(self, registers, at):
        """A 32-bit field of the status block (high word first, docs/modbus.md)."""
        i = at - self.block.first
        return (registers[i] << 16) | registers[i + 1]

    def check(self, cycle_s):
        self.stop_flag.set()
        self.join(5)
        assert not self.errors, self.errors[:5]
        (t0, dx0, m0), (t1, dx1, m1) = self.samples[0], self.samples[-1]
        stalled = self.stalled_s() - self.stalled0
        due = (t1 - t0 - stalled) / cycle_s
        worst = max(self.latencies)
        print("Modbus: %d reads, slowest %.1f ms; DP: %d Data_Exchanges of %.0f due, %d missed; "
              "host stalls %.0f ms" % (len(self.latencies), worst * 1000, dx1 - dx0, due, m1 - m0,
                                       stalled * 1000))
        assert worst < 0.5, worst
        assert dx1 - dx0 >= 0.9 * due, (dx1 - dx0, due)
        assert m1 - m0 <= 0.05 * due, (m1 - m0, due)


@pytest.fixture(scope="module")
def d(candp2_binary):
    raise_descriptor_limit()
    daemon = Daemon(candp2_binary, config=config(idle_timeout_s=IDLE_TIMEOUT_S))
    try:
        daemon.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        watch = Watch(daemon)
        watch.start()
        yield daemon
        watch.check(CYCLE_S)
    finally:
        daemon.stop()


def timed_get(d, path="/api/v1/status", timeout=5.0):
    t = time.monotonic()
    with urllib.request.urlopen(d.base + path, timeout=timeout) as r:
        body = r.read()
        assert r.status == 200
    return time.monotonic() - t, body


def open_many(port, n, deadline_s=10.0):
    """n non-blocking connects; returns the sockets once every one is connected (or failed)."""
    socks, pending = [], {}
    for _ in range(n):
        s = socket.socket()
        s.setblocking(False)
        try:
            s.connect(("127.0.0.1", port))
        except BlockingIOError:
            pass
        socks.append(s)
        pending[s.fileno()] = s
    poll = select.poll()
    for fd in pending:
        poll.register(fd, select.POLLOUT)
    end = time.monotonic() + deadline_s
    while pending and time.monotonic() < end:
        for fd, _ in poll.poll(100):
            poll.unregister(fd)
            pending.pop(fd, None)
    return socks, len(pending)


def test_1_burst_of_1000_ten_times(d):
    for _ in range(10):
        socks, _ = open_many(d.http_port, 1000, deadline_s=3.0)
        for s in socks:
            s.close()
    took, body = timed_get(d, timeout=1.0)
    assert took < 1.0, took
    http = json.loads(body)["http"]
    assert http["clients_evicted"] > 0, http  # 1000 > http.max_clients (64)
    print("after 10 x 1000 connections: answered in %.1f ms (%d accepted, %d evicted)"
          % (took * 1000, http["clients_accepted"], http["clients_evicted"]))


def test_2_1000_idle_connections_evict_the_oldest(d):
    socks, unconnected = open_many(d.http_port, 1000)
    try:
        assert unconnected == 0, unconnected
        took, body = timed_get(d, timeout=1.0)
        assert took < 1.0, took
        s = json.loads(body)["http"]
        assert s["connections"] <= 64 + 1, s
        print("1000 idle connections, limit 64: answered in %.1f ms" % (took * 1000))
    finally:
        for s in socks:
            s.close()


def test_3_trickling_headers_are_cut(d):
    tricklers = []
    for _ in range(50):
        s = socket.create_connection(("127.0.0.1", d.http_port), timeout=5)
        s.setblocking(False)
        tricklers.append(s)
    header = b"GET /api/v1/status HTTP/1.1\r\nHost: x\r\nX-Slow: " + b"a" * 100
    start = time.monotonic()
    cut = {}  # socket -> seconds after start
    answered = []
    i = 0
    try:
        while len(cut) < len(tricklers) and time.monotonic() - start < IDLE_TIMEOUT_S + 3:
            for s in tricklers:
                if s in cut:
                    continue
                try:
                    data = s.recv(4096)
                    if data:
                        answered.append(data[:40])
                    cut[s] = time.monotonic() - start  # EOF (or an answer: asserted below)
                    continue
                except BlockingIOError:
                    pass
                except OSError:  # reset
                    cut[s] = time.monotonic() - start
                    continue
                try:
                    s.send(header[i % len(header):i % len(header) + 1])
                except OSError:
                    cut[s] = time.monotonic() - start
            i += 1
            took, _ = timed_get(d, timeout=1.0)  # others are served meanwhile
            assert took < 1.0, took
            time.sleep(max(0.0, start + i - time.monotonic()))  # a byte a second
    finally:
        for s in tricklers:
            s.close()
    assert not answered, answered
    assert len(cut) == len(tricklers), "%d of 50 still open" % (len(tricklers) - len(cut))
    latest = max(cut.values())
    assert IDLE_TIMEOUT_S - 0.5 <= min(cut.values()) and latest <= IDLE_TIMEOUT_S + 2, cut.values()
    s = d.status()["http"]
    assert s["clients_timed_out"] >= 50, s
    print("50 trickling headers cut after %.1f..%.1f s" % (min(cut.values()), latest))


def test_4_a_200_kB_header_is_refused(d):
    s = socket.create_connection(("127.0.0.1", d.http_port), timeout=5)
    request = (b"GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + b"b" * 200_000 + b"\r\n\r\n")
    sent, reply = 0, b""
    end = time.monotonic() + 5
    s.setblocking(False)
    try:
        while time.monotonic() < end:
            try:
                chunk = s.recv(65536)
                if not chunk:
                    break
                reply += chunk
            except BlockingIOError:
                pass
            except ConnectionResetError:
                break
            if sent < len(request):
                try:
                    sent += s.send(request[sent:sent + 16384])
                except BlockingIOError:
                    time.sleep(0.01)
                except (BrokenPipeError, ConnectionResetError):
                    sent = len(request)
            else:
                time.sleep(0.01)
    finally:
        s.close()
    # libmicrohttpd's answer to a header beyond its per-connection memory: 431, then it closes.
    # A reset may overtake the answer on the client's side; then nothing at all was answered.
    if reply:
        assert reply.startswith(b"HTTP/1.1 431"), reply[:80]
    assert time.monotonic() < end, "the connection stayed open"
    took, _ = timed_get(d, timeout=1.0)
    assert took < 1.0
    print("200 kB header: %s, %d bytes taken before" % (reply.split(b"\r\n")[0] or b"reset", sent))


def test_5_1000_idle_connections_held(candp2_binary):
    """With http.max_clients above 1000 the daemon holds them all and still serves a new
    client at once."""
    if raise_descriptor_limit() < 2200:
        pytest.skip("descriptor limit below 2200")
    daemon = Daemon(candp2_binary, config=config(max_clients=1100))
    socks = []
    try:
        daemon.wait_for("Data_Exch", lambda s: s["gateways"][0]["dp_state"] == "Data_Exch")
        watch = Watch(daemon)
        watch.start()
        socks, unconnected = open_many(daemon.http_port, 1000)
        assert unconnected == 0, unconnected
        daemon.wait_for("1000 connections held",
                        lambda s: s["http"]["connections"] >= 1001, timeout=10)
        took, body = timed_get(daemon, timeout=1.0)
        assert took < 1.0, took
        assert json.loads(body)["http"]["clients_evicted"] == 0
        time.sleep(1.0)  # the held connections cost the DP cycle nothing either
        watch.check(CYCLE_S)
        print("1000 idle connections held: answered in %.1f ms" % (took * 1000))
    finally:
        for s in socks:
            try:
                s.close()
            except OSError as e:
                assert e.errno == errno.EBADF
        daemon.stop()
