#!/usr/bin/python3
"""packaging/systemd/candp2d.service and the template candp2d@.service pass `systemd-analyze
verify`, and the template differs from the unit only in its instance lines.

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
TEMPLATE = os.path.join(ROOT, "packaging", "systemd", "candp2d@.service")
# What the template may change of the unit (docs/daemon.md "Several lines on one host"): the
# instance's name in the description, its configuration /etc/candp2/%i.json, its own state and
# logs folders. Every other line (the hardening above all) stays the unit's.
TEMPLATE_LINES = {
    "Description=candp2d - emulator of the esd CAN-DP/2 PROFIBUS-DP/CAN gateway":
        "Description=candp2d %i - emulator of the esd CAN-DP/2 PROFIBUS-DP/CAN gateway",
    "ExecStart=/usr/bin/candp2d --config /etc/candp2/candp2d.json":
        "ExecStart=/usr/bin/candp2d --config /etc/candp2/%i.json",
    "StateDirectory=candp2": "StateDirectory=candp2/%i",
    "LogsDirectory=candp2": "LogsDirectory=candp2/%i",
}
DROPINS = ["candp2d-bitrate-apply.conf", "candp2d-serial.conf"]


def verify(path):
    r = subprocess.run(["systemd-analyze", "verify", "--man=no", path], capture_output=True,
                       text=True, timeout=60)
    # Messages about other units of this machine (verify loads the default dependencies) are not
    # ours; keep those naming our unit or its files.
    ours = [l for l in (r.stdout + r.stderr).splitlines() if "candp2d" in l]
    return r.returncode, ours


def settings(path):
    """The unit's key=value lines (comments and blank lines left out), in order."""
    with open(path) as f:
        return [l.strip() for l in f if l.strip() and not l.startswith("#")]


def unit_copy(tmp, candp2d, transform=lambda text: text, dropins=(), unit=UNIT):
    with open(unit) as f:
        text = f.read()
    if text.count("ExecStart=/usr/bin/candp2d ") != 1:
        raise SystemExit("FAIL: the unit must start /usr/bin/candp2d exactly once")
    text = transform(text.replace("ExecStart=/usr/bin/candp2d ", "ExecStart=%s " % candp2d))
    d = tempfile.mkdtemp(dir=tmp)
    path = os.path.join(d, os.path.basename(unit))
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

        # The template, as two instances (verify needs an instance name; the template file
        # beside it is what it loads).
        template = unit_copy(tmp, candp2d, unit=TEMPLATE)
        for instance in ("line1", "line2"):
            rc, ours = verify(template.replace("@.service", "@%s.service" % instance))
            if rc != 0 or ours:
                print("FAIL: template instance %s: exit %d:\n  %s" % (instance, rc,
                                                                       "\n  ".join(ours)))
                failed += 1
            else:
                print("ok: template instance %s verifies cleanly" % instance)
        broken = unit_copy(tmp, candp2d, lambda t: t.replace("ProtectSystem=", "ProtectSystm="),
                           unit=TEMPLATE)
        rc, ours = verify(broken.replace("@.service", "@line1.service"))
        if not any("ProtectSystm" in l for l in ours):
            print("FAIL: a misspelt key in the template not reported (exit %d): %s" % (rc, ours))
            failed += 1
        expected = [TEMPLATE_LINES.get(l, l) for l in settings(UNIT)]
        if settings(TEMPLATE) != expected:
            diff = [(a, b) for a, b in zip(expected, settings(TEMPLATE)) if a != b]
            print("FAIL: the template differs from the unit beyond its instance lines: %s"
                  % (diff or "(lines added or removed)"))
            failed += 1
        else:
            print("ok: the template is the unit but for %d instance lines" % len(TEMPLATE_LINES))

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
