#!/usr/bin/python3
"""One watchdog rule, one verdict (docs/validate.md "The watchdog rule"): six configurations, the
watchdog against the master cycle, the bus cycle, its retries and the rotation that parameterizes
every station, on the ideal line, at 9.6 kbit/s and at 1.5 Mbit/s. For each, `candp2 validate
--json`, `candp2d --check` and candp2d's warnings at start give the expected verdict (holds, a
warning, or an error that makes the file invalid) in the same words at the same JSON path.

Bounded: every run has a timeout; the started daemon listens on 127.0.0.1 (any free port) only
and is stopped as soon as it says it is ready.

  watchdog_verdict_test.py --candp2d build/bin/candp2d --candp2 build/bin/candp2
"""

import argparse
import json
import os
import re
import selectors
import subprocess
import sys
import tempfile
import time

WARNING = re.compile(r"^candp2d: (warning|error): [^:]+: (\$[^:]*\.watchdog_ms): (.*)$")


def gateway(name, address, bus, watchdog_ms):
    """A CAN-DP/2 with 5 output and 6 input bytes (as config/line-9600.json's)."""
    return {"name": name, "address": address, "bus": bus,
            "parameters": {"can_bitrate": "500k", "watchdog_ms": watchdog_ms},
            "slots": [{"io": "output", "address": 16 * (address - 3), "length": 5,
                       "comment": "02,01,00"},
                      {"io": "input", "address": 16 * (address - 3), "length": 6,
                       "comment": "01,81,00"}]}


def configuration(baud, cycle_ms, watchdogs):
    master = {"address": 1, "cycle_ms": cycle_ms, "host_stall_ms": 50}
    if baud:
        master["baud"] = baud
    return {"modbus": {"listen": "127.0.0.1:0"}, "master": master,
            "buses": {"can0": {"type": "virtual"}},
            "gateways": [gateway("gw%d" % i, 3 + i, "can0", w) for i, w in enumerate(watchdogs)]}


# name, baud (None: ideal), cycle_ms, the gateways' watchdogs, expected verdict, a phrase of the
# expected message (the term that decides).
CASES = [
    ("ideal-master-cycle", None, 20, [10], "error", "shorter than the master cycle itself"),
    ("9600-bus-cycle", 9600, 10, [50, 50], "error", "shorter than the bus cycle itself"),
    # At 9.6 kbit/s cycle_ms 100 and watchdog 200 expired 22 times in 9 s.
    ("9600-parameterization", 9600, 100, [200], "warning",
     "the rotation that parameterizes every station"),
    ("9600-retries", 9600, 300, [320], "warning", "the master cycle 300.00 ms with its retries"),
    # cycle_ms 300, watchdog 500 stays in Data_Exch (candp2d used to warn).
    ("9600-holds", 9600, 300, [500], "holds", None),
    ("1500k-late-cycle", 1500000, 10, [40, 200], "warning",
     "the master cycle 10.00 ms with its retries"),
]


def run(argv):
    return subprocess.run(argv, capture_output=True, text=True, timeout=60)


def from_validate(candp2, path):
    r = run([candp2, "validate", "--json", path])
    doc = json.loads(r.stdout)
    found = {(p["severity"], p["json_path"], p["message"])
             for p in doc["line"].get("problems", []) if p["json_path"].endswith("watchdog_ms")}
    return r.returncode, found


def from_lines(text):
    found = set()
    for line in text.splitlines():
        m = WARNING.match(line)
        if m:
            found.add(m.groups())
    return found


def from_check(candp2d, path):
    r = run([candp2d, "--check", "--config", path])
    return r.returncode, from_lines(r.stderr)


def from_start(candp2d, path):
    """The warnings candp2d prints when it starts, up to "ready:"; then SIGTERM."""
    p = subprocess.Popen([candp2d, "--config", path], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    text, ready = "", False
    try:
        sel = selectors.DefaultSelector()
        sel.register(p.stdout, selectors.EVENT_READ)
        deadline = time.monotonic() + 20
        while not ready and time.monotonic() < deadline:
            if not sel.select(timeout=max(0.0, deadline - time.monotonic())):
                break
            line = p.stdout.readline()
            if not line:
                break
            text += line
            ready = "ready:" in line
    finally:
        p.terminate()
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    return ready, text, from_lines(text)


def verdict(severities):
    return "error" if "error" in severities else "warning" if severities else "holds"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--candp2", required=True)
    args = ap.parse_args()
    failed = 0
    with tempfile.TemporaryDirectory(prefix="candp2-watchdog-") as tmp:
        for name, baud, cycle_ms, watchdogs, expected, phrase in CASES:
            path = os.path.join(tmp, name + ".json")
            with open(path, "w") as f:
                json.dump(configuration(baud, cycle_ms, watchdogs), f, indent=1)
            rc_v, v = from_validate(args.candp2, path)
            rc_c, c = from_check(args.candp2d, path)
            ready, started_text, s = from_start(args.candp2d, path)
            # Running, an error is a warning (docs/configuration.md "Warnings").
            started = {("error" if "can never hold" in m else "warning", p, m) for _, p, m in s}
            problems = []
            if not ready:
                problems.append("candp2d did not get ready:\n" + started_text[-800:])
            if {(p, m) for _, p, m in v} != {(p, m) for _, p, m in c} or v != c:
                problems.append("validate and --check differ:\n  %s\n  %s" % (sorted(v), sorted(c)))
            if c != started:
                problems.append("--check and the start differ:\n  %s\n  %s" %
                                (sorted(c), sorted(started)))
            got = [verdict({sev for sev, _, _ in x}) for x in (v, c, started)]
            if got != [expected] * 3:
                problems.append("verdicts validate/--check/start %s, expected %s" % (got, expected))
            want_rc = 1 if expected == "error" else 0
            if (rc_v, rc_c) != (want_rc, want_rc):
                problems.append("exit codes validate %d, --check %d, expected %d" %
                                (rc_v, rc_c, want_rc))
            if phrase and not any(phrase in m for _, _, m in v):
                problems.append("no message says %r: %s" % (phrase, sorted(v)))
            if problems:
                failed += 1
                print("FAIL: %s:\n  %s" % (name, "\n  ".join(problems)))
            else:
                print("ok: %s: %s from all three%s" % (
                    name, expected, "".join("\n    " + p + ": " + m for _, p, m in sorted(v))))
    print("%d passed, %d failed" % (len(CASES) - failed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
