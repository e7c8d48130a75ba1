#!/usr/bin/python3
"""`candp2 sniff pty:PATH` end to end (docs/sniff.md): the sniffer opens a pseudo-terminal, this
test opens PATH like a master's serial port and writes telegrams (whole telegrams per write:
characters inside a telegram have no gaps).

Default: three telegrams of the docs/profibus.md capture; the sniffer must print one decoded line
each with a time stamp, exit after -n 3 and remove PATH.

--stats (docs/sniff.md "Line statistics: --stats"): a token rotation in which station 3 answers a
Slave_Diag and station 5 does not (one repeat), then another token. The sniffer prints a JSON line
every second; once one shows all 7 telegrams, SIGINT ends it and its last line must hold exactly
the counters of that scenario, with token rotation times (a line has times)."""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

TOKEN = "DC 02 02"
DIAG3 = "68 05 05 68 83 82 6D 3C 3E EC 16"  # Slave_Diag 2->3 (docs/profibus.md capture)
DIAG3_ANSWER = "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16"
DIAG5 = "68 05 05 68 85 82 6D 3C 3E EE 16"  # Slave_Diag 2->5: nobody answers
STATS_SCENARIO = [TOKEN, DIAG3, DIAG3_ANSWER, TOKEN, DIAG5, DIAG5, TOKEN]


def run(candp2, options, telegrams, after_writes):
    """Starts the sniffer on a pty, writes `telegrams` into it, calls after_writes(proc) and
    returns (exit status, stdout lines read by after_writes and after, stderr, link exists)."""
    with tempfile.TemporaryDirectory() as tmp:
        link = os.path.join(tmp, "line")
        proc = subprocess.Popen([candp2, "sniff", "--baud", "19200"] + options + ["pty:" + link],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 10
            while not os.path.islink(link):
                if proc.poll() is not None or time.monotonic() > deadline:
                    return None, [], "sniffer did not create %s: %s" % (link, proc.stderr.read()), 0
                time.sleep(0.01)
            fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
            for telegram in telegrams:
                os.write(fd, bytes.fromhex(telegram))
                time.sleep(0.05)  # > TSYN at 19200 baud: each write is one telegram
            lines = after_writes(proc, deadline)
            out, err = proc.communicate(timeout=10)
            os.close(fd)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        return proc.returncode, lines + out.splitlines(), err, os.path.lexists(link)


def decode_test(candp2):
    rc, lines, err, link_left = run(
        candp2, ["-n", "3"], ["10 03 02 49 4E 16", DIAG3, "E5"], lambda proc, deadline: [])
    expected = ["SD1 2->3 FDL_Status.req",
                "SD2 2->3 [62->60] SRD_high FCB=1 FCV=0 Slave_Diag.req",
                "SC Slave_Diag.res 3->2"]
    ok = rc == 0 and len(lines) == 3
    for line, want in zip(lines, expected):
        stamp, _, text = line.partition(" ")
        ok = ok and stamp.startswith("(") and stamp.endswith(")") and text == want
    return ok and not link_left, lines, err


def stats_test(candp2):
    def await_report(proc, deadline):
        # The per-second reports: wait for the one that has seen everything, then SIGINT.
        lines = []
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line.rstrip("\n"))
            if json.loads(line)["telegrams"] == len(STATS_SCENARIO):
                break
        proc.send_signal(signal.SIGINT)
        return lines

    rc, lines, err, _ = run(candp2, ["--stats", "--json"], STATS_SCENARIO, await_report)
    last = json.loads(lines[-1]) if lines else {}
    want_stations = [
        {"address": 3, "live": "ok", "lost": 0, "syncs": 0, "repeats": 0, "repeats_max": 0,
         "illegals": 0, "diagnostics": 1},
        {"address": 5, "live": "missing", "lost": 0, "syncs": 0, "repeats": 1, "repeats_max": 1,
         "illegals": 0, "diagnostics": 0},
    ]
    ok = rc == 0 and len(lines) >= 2 and last.get("stations") == want_stations
    ok = ok and last.get("live_list") == {"ok": [3], "missing": [5], "phantom": []}
    ok = ok and last.get("telegrams") == len(STATS_SCENARIO)
    ok = ok and last.get("illegals_unattributed") == 0
    rot = last.get("rotation_us") or {}
    # Three tokens, each three writes (3 x 50 ms) after the one before.
    ok = ok and rot.get("count") == 2 and 100_000 <= rot["min"] <= rot["mean"] <= rot["max"]
    return ok and rot["last"] in (rot["min"], rot["max"]), lines, err


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2", required=True)
    ap.add_argument("--stats", action="store_true", help="the --stats --json test")
    args = ap.parse_args()
    ok, lines, err = (stats_test if args.stats else decode_test)(args.candp2)
    if not ok:
        print("stdout:", lines, "stderr:", err, file=sys.stderr)
        return 1
    print("sniff pty%s: ok" % (" --stats" if args.stats else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
