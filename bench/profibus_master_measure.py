#!/usr/bin/python3
"""Data_Exchange round trips per second: candp2d role "master" driving a candp2d role "slaves"
over a pseudo-terminal (docs/profibus.md "Performance").

    /usr/bin/python3 bench/profibus_master_measure.py --candp2d build/bin/candp2d \
        --gateways 1 --cycle-ms 1 --baud 19200 --seconds 5

S emulates N gateways (manual §5.1.4 slots, one virtual CAN bus each) on pty:<tmp>/pb; M drives
them as remote stations, every cycle_ms one Data_Exchange per station. Once every station is in
Data_Exch on M, M's Data_Exchange counters (status field data_exchanges per unit) are read twice,
`--seconds` apart; the rate is their growth. Also printed: M's per-station response times
(response_us, response_max_us) and retries (station_retries). Both daemons run as candp2.Daemon
(python/, docs/python.md): free ports, ready on READY=1, status fields by name.
"""
import argparse
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "python"))
# python/ is on sys.path at run time only: mypy run from bench/ sees candp2 as Any.
import candp2  # noqa: E402


def slots(i: int) -> list[dict[str, object]]:
    return [{"io": "input", "address": 8 * i, "length": 6, "comment": "02,89,B8"},
            {"io": "output", "address": 8 * i, "length": 6, "comment": "03,09,B8"}]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--gateways", type=int, default=1)
    ap.add_argument("--cycle-ms", type=int, default=1)
    ap.add_argument("--baud", type=int, default=19200)
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="candp2-pbm-")
    link = os.path.join(tmp, "pb")
    addrs = [3 + i for i in range(a.gateways)]
    s_cfg = {"profibus": {"port": "pty:" + link, "baud": a.baud, "role": "slaves"},
             "buses": {"can%d" % i: {"type": "virtual"} for i in range(a.gateways)},
             "gateways": [{"name": "gw%d" % d, "address": d, "bus": "can%d" % i, "slots": slots(i)}
                          for i, d in enumerate(addrs)],
             "log": {"level": "warn"}}
    m_cfg = {"master": {"address": 2, "cycle_ms": a.cycle_ms, "retry_ms": 100},
             "profibus": {"port": link, "baud": a.baud, "role": "master"},
             "gateways": [{"name": "gw%d" % d, "address": d, "slots": slots(i)}
                          for i, d in enumerate(addrs)],
             "log": {"level": "warn"}}
    daemons: list[candp2.Daemon] = []
    try:
        daemons.append(candp2.Daemon(s_cfg, a.candp2d))
        m = candp2.Daemon(m_cfg, a.candp2d)
        daemons.append(m)
        stations = [m.gateway(d) for d in addrs]
        for g in stations:
            g.wait_until(lambda g: g.state == "Data_Exch", timeout=20)

        def num(v: object) -> int:  # a counter of the status (its type allows tuples too)
            assert isinstance(v, int)
            return v

        def exchanges() -> int:
            return sum(num(g.status["data_exchanges"]) for g in stations)

        n0, t0 = exchanges(), time.monotonic()
        time.sleep(a.seconds)
        n1, t1 = exchanges(), time.monotonic()
        blocks = [g.status for g in stations]
        rate = (n1 - n0) / (t1 - t0)
        last = sorted(num(b["response_us"]) for b in blocks)
        print("gateways %d, cycle_ms %d, baud %d: %.0f Data_Exchange/s (%.0f per station), "
              "response last median %d us, max %d us, retries %d" % (
                  a.gateways, a.cycle_ms, a.baud, rate, rate / a.gateways, last[len(last) // 2],
                  max(num(b["response_max_us"]) for b in blocks),
                  sum(num(b["station_retries"]) for b in blocks)))
    finally:
        for d in reversed(daemons):
            d.stop(check=False)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
