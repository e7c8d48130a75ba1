#!/usr/bin/python3
"""`candp2 sniff pty:PATH` end to end (docs/sniff.md): the sniffer opens a pseudo-terminal, this
test opens PATH like a master's serial port and writes three telegrams of the docs/profibus.md
capture (whole telegrams per write: characters inside a telegram have no gaps); the sniffer must
print one decoded line each with a time stamp, exit after -n 3 and remove PATH."""
import argparse
import os
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2", required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        link = os.path.join(tmp, "line")
        proc = subprocess.Popen([args.candp2, "sniff", "-n", "3", "--baud", "19200", "pty:" + link],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 10
            while not os.path.islink(link):
                if proc.poll() is not None or time.monotonic() > deadline:
                    print("sniffer did not create", link, proc.stderr.read(), file=sys.stderr)
                    return 1
                time.sleep(0.01)
            fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
            for telegram in ("10 03 02 49 4E 16", "68 05 05 68 83 82 6D 3C 3E EC 16", "E5"):
                os.write(fd, bytes.fromhex(telegram))
                time.sleep(0.05)  # > TSYN at 19200 baud: each write is one telegram
            out, err = proc.communicate(timeout=10)
            os.close(fd)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        lines = out.splitlines()
        expected = ["SD1 2->3 FDL_Status.req",
                    "SD2 2->3 [62->60] SRD_high FCB=1 FCV=0 Slave_Diag.req",
                    "SC Slave_Diag.res 3->2"]
        ok = proc.returncode == 0 and len(lines) == 3
        for line, want in zip(lines, expected):
            stamp, _, text = line.partition(" ")
            ok = ok and stamp.startswith("(") and stamp.endswith(")") and text == want
        ok = ok and not os.path.lexists(link)
        if not ok:
            print("exit", proc.returncode, "stdout:", out, "stderr:", err, file=sys.stderr)
            return 1
    print("sniff pty: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
