#!/usr/bin/python3
"""packaging/systemd/candp2d.service passes `systemd-analyze verify`.

verify checks the unit's syntax, every key and value, and that ExecStart's binary exists and is
executable. /usr/bin/candp2d is not installed on a build machine, so the test verifies a copy whose
ExecStart names the freshly built candp2d (nothing else changes), together with the two example
drop-ins (packaging/systemd/*.conf) placed in its .d directory. It also shows that verify would
catch a mistake: a copy with a misspelt key and one with a missing binary must be reported.

  unit_verify.py --candp2d build/bin/candp2d
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UNIT = os.path.join(ROOT, "packaging", "systemd", "candp2d.service")
DROPINS = ["candp2d-bitrate-apply.conf", "candp2d-serial.conf"]


def verify(path):
    r = subprocess.run(["systemd-analyze", "verify", "--man=no", path], capture_output=True,
                       text=True, timeout=60)
    # Messages about other units of this machine (verify loads the default dependencies) are not
    # ours; keep those naming our unit or its files.
    ours = [l for l in (r.stdout + r.stderr).splitlines() if "candp2d" in l]
    return r.returncode, ours


def unit_copy(tmp, candp2d, transform=lambda text: text, dropins=()):
    with open(UNIT) as f:
        text = f.read()
    if text.count("ExecStart=/usr/bin/candp2d ") != 1:
        raise SystemExit("FAIL: the unit must start /usr/bin/candp2d exactly once")
    text = transform(text.replace("ExecStart=/usr/bin/candp2d ", "ExecStart=%s " % candp2d))
    d = tempfile.mkdtemp(dir=tmp)
    path = os.path.join(d, "candp2d.service")
    with open(path, "w") as f:
        f.write(text)
    if dropins:
        os.mkdir(path + ".d")
        for name in dropins:
            shutil.copy(os.path.join(ROOT, "packaging", "systemd", name), path + ".d")
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    args = ap.parse_args()
    candp2d = os.path.abspath(args.candp2d)
    failed = 0
    with tempfile.TemporaryDirectory(prefix="candp2-unit-") as tmp:
        # The unit as shipped (and with its example drop-ins): no message at all.
        for dropins in ((), DROPINS):
            rc, ours = verify(unit_copy(tmp, candp2d, dropins=dropins))
            what = "unit" + (" + " + ", ".join(dropins) if dropins else "")
            if rc != 0 or ours:
                print("FAIL: %s: systemd-analyze verify exit %d:\n  %s" % (what, rc,
                                                                            "\n  ".join(ours)))
                failed += 1
            else:
                print("ok: %s verifies cleanly" % what)

        # Verify does look: a misspelt key and a missing binary are reported.
        cases = [
            ("misspelt key", lambda t: t.replace("ProtectSystem=strict", "ProtectSystm=strict"),
             r"ProtectSystm"),
            ("missing binary", lambda t: re.sub(r"ExecStart=\S+", "ExecStart=/nonexistent/candp2d",
                                                t), r"/nonexistent/candp2d"),
        ]
        for name, transform, pattern in cases:
            rc, ours = verify(unit_copy(tmp, candp2d, transform))
            if not any(re.search(pattern, l) for l in ours):
                print("FAIL: %s not reported (exit %d): %s" % (name, rc, ours))
                failed += 1
            else:
                print("ok: %s reported: %s" % (name, ours[0]))

        # The documented values, so that a later edit cannot silently drop them.
        with open(UNIT) as f:
            unit = f.read()
        for line in ("Type=notify", "ExecStart=/usr/bin/candp2d --config /etc/candp2/candp2d.json",
                     "DynamicUser=yes", "StateDirectory=candp2", "ProtectSystem=strict",
                     "CapabilityBoundingSet=", "NoNewPrivileges=yes", "WatchdogSec=10s",
                     "RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6 AF_CAN AF_NETLINK"):
            if not re.search("^%s$" % re.escape(line), unit, re.M):
                print("FAIL: the unit lacks %r" % line)
                failed += 1
    print("%s" % ("unit verify passed" if not failed else "%d failed" % failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
