#!/usr/bin/python3
"""Data_Exchange round trips per second: candp2d role "master" driving a candp2d role "slaves" over a
pseudo-terminal (emulator-spec §10, docs/profibus.md "Performance").

    /usr/bin/python3 bench/profibus_master_measure.py --candp2d build/bin/candp2d \
        --gateways 1 --cycle-ms 1 --baud 19200 --seconds 5

S emulates N gateways (manual §5.1.4 slots, one virtual CAN bus each) on pty:<tmp>/pb; M drives
them as remote stations, every cycle_ms one Data_Exchange per station. Once every station is in
Data_Exch on M, M's Data_Exchange counters (status block 8220..8221 per unit) are read twice,
`--seconds` apart; the rate is their growth. Also printed: M's per-station response times
(8246/8247) and retries (8244..8245).
"""
import argparse
import json
import os
import shutil
import socket
import subprocess
import tempfile
import time

from pymodbus.client import ModbusTcpClient  # python3-pymodbus


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def slots(i):
    return [{"io": "input", "address": 8 * i, "length": 6, "comment": "02,89,B8"},
            {"io": "output", "address": 8 * i, "length": 6, "comment": "03,09,B8"}]


def start(candp2d, tmp, name, cfg, port):
    path = os.path.join(tmp, name + ".json")
    with open(path, "w") as f:
        json.dump(cfg, f)
    log = open(os.path.join(tmp, name + ".log"), "w")
    p = subprocess.Popen([candp2d, "--config", path], stdout=log, stderr=subprocess.STDOUT)
    end = time.monotonic() + 10
    while time.monotonic() < end:
        if p.poll() is not None:
            raise SystemExit(name + " exited:\n" + open(log.name).read())
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return p
        except OSError:
            time.sleep(0.02)
    raise SystemExit(name + " did not listen")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--gateways", type=int, default=1)
    ap.add_argument("--cycle-ms", type=int, default=1)
    ap.add_argument("--baud", type=int, default=19200)
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="candp2-pbm-")
    link = os.path.join(tmp, "pb")
    sp, mp = free_port(), free_port()
    addrs = [3 + i for i in range(a.gateways)]
    s_cfg = {"modbus": {"listen": "127.0.0.1:%d" % sp},
             "profibus": {"port": "pty:" + link, "baud": a.baud, "role": "slaves"},
             "buses": {"can%d" % i: {"type": "virtual"} for i in range(a.gateways)},
             "gateways": [{"name": "gw%d" % d, "address": d, "bus": "can%d" % i, "slots": slots(i)}
                          for i, d in enumerate(addrs)],
             "log": {"level": "warn"}}
    m_cfg = {"modbus": {"listen": "127.0.0.1:%d" % mp},
             "master": {"address": 2, "cycle_ms": a.cycle_ms, "retry_ms": 100},
             "profibus": {"port": link, "baud": a.baud, "role": "master"},
             "gateways": [{"name": "gw%d" % d, "address": d, "slots": slots(i)}
                          for i, d in enumerate(addrs)],
             "log": {"level": "warn"}}
    procs = []
    try:
        procs.append(start(a.candp2d, tmp, "S", s_cfg, sp))
        procs.append(start(a.candp2d, tmp, "M", m_cfg, mp))
        c = ModbusTcpClient("127.0.0.1", port=mp, timeout=3)
        assert c.connect()

        def block(d):
            r = c.read_input_registers(8192, 57, slave=d)
            assert not r.isError(), r
            return r.registers

        end = time.monotonic() + 20
        while not all(block(d)[0] == 2 for d in addrs):
            if time.monotonic() > end:
                raise SystemExit("not all stations in Data_Exch")
            time.sleep(0.05)

        def exchanges():
            return sum((b[28] << 16) | b[29] for b in map(block, addrs))

        n0, t0 = exchanges(), time.monotonic()
        time.sleep(a.seconds)
        n1, t1 = exchanges(), time.monotonic()
        blocks = [block(d) for d in addrs]
        rate = (n1 - n0) / (t1 - t0)
        last = sorted(b[54] for b in blocks)
        print("gateways %d, cycle_ms %d, baud %d: %.0f Data_Exchange/s (%.0f per station), "
              "response last median %d us, max %d us, retries %d" % (
                  a.gateways, a.cycle_ms, a.baud, rate, rate / a.gateways, last[len(last) // 2],
                  max(b[55] for b in blocks), sum((b[52] << 16) | b[53] for b in blocks)))
        c.close()
    finally:
        for p in procs:
            p.terminate()
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
