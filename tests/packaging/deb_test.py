#!/usr/bin/python3
"""The Debian package of tools/setup.sh deb (packaging/deb/build-deb.sh):

  - contents (dpkg-deb -c): the executables, GSD, examples, man pages, unit, configuration,
    copyright and changelog in Debian's places, owned by root; no tests, benchmarks, headers or
    static libraries; the example drop-ins are not active (nothing under /etc/systemd);
  - control (dpkg-deb -f): Package, Version, Architecture, Depends computed from the shared
    libraries (libmodbus, libmicrohttpd, spdlog, fmt, libc, libstdc++; not libsystemd, whose
    sd_notify protocol candp2d speaks itself, docs/daemon.md "systemd");
  - conffiles: exactly /etc/candp2/candp2d.json; maintainer scripts are valid sh;
  - lintian: exit status 0 with --fail-on error,warning;
  - the installed tree (dpkg-deb -x): candp2d --version, candp2d --check on the installed
    configuration (whose state_file lies in the unit's StateDirectory), candp2 gsd on the GSD;
  - two instances of the template candp2d@.service (docs/daemon.md "Several lines on one
    host"): its ExecStart for line1 and line2, each with its own configuration, run side by side
    and both answer Modbus.

  deb_test.py --deb dist/candp2_0.1.0-1_amd64.deb --version 0.1.0
"""

import argparse
import json
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import time

SKIP = 77


def run(argv, **kw):
    return subprocess.run(argv, capture_output=True, text=True, timeout=240, **kw)


class Checks:
    def __init__(self):
        self.failed = 0

    def check(self, ok, what, detail=""):
        print(("ok: " if ok else "FAIL: ") + what + ("" if ok or not detail else "\n  " + detail))
        if not ok:
            self.failed += 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--deb", required=True)
    ap.add_argument("--version", required=True)
    args = ap.parse_args()
    if not os.path.exists(args.deb):
        print("SKIP: %s not built (tools/setup.sh deb builds it)" % args.deb)
        return SKIP
    c = Checks()

    # Contents.
    listing = run(["dpkg-deb", "-c", args.deb]).stdout.splitlines()
    paths = {}
    for line in listing:
        f = line.split()
        paths[f[5].lstrip(".")] = (f[0], f[1])
    required = [
        "/usr/bin/candp2d", "/usr/bin/candp2", "/usr/bin/candp2-drive",
        "/usr/share/candp2/gsd/CDPS04A4.GSD",
        "/usr/share/candp2/examples/demo.json",
        "/usr/share/candp2/examples/scenarios/slots-manual-5.1.4.json",
        "/usr/share/candp2/examples/systemd/candp2d-bitrate-apply.conf",
        "/usr/share/candp2/examples/systemd/candp2d-serial.conf",
        "/usr/share/candp2/wireshark/candp2.lua",
        "/usr/share/man/man8/candp2d.8.gz", "/usr/share/man/man1/candp2.1.gz",
        "/usr/share/man/man1/candp2-drive.1.gz",
        "/usr/share/doc/candp2/copyright", "/usr/share/doc/candp2/changelog.Debian.gz",
        "/lib/systemd/system/candp2d.service", "/lib/systemd/system/candp2d@.service",
        "/etc/candp2/candp2d.json",
    ]
    missing = [p for p in required if p not in paths]
    c.check(not missing, "contents: %d required files" % len(required), "missing %s" % missing)
    for exe in ("/usr/bin/candp2d", "/usr/bin/candp2", "/usr/bin/candp2-drive"):
        c.check(paths.get(exe, ("", ""))[0] == "-rwxr-xr-x", exe + " is 0755",
                str(paths.get(exe)))
    owners = {o for _, o in paths.values()}
    c.check(owners == {"root/root"}, "every file owned by root/root", str(owners))
    unwanted = [p for p in paths if re.search(
        r"(^|/)(tests?|bench|fuzz|include)(/|$)|\.(a|hpp|h|o)$|_tests?$|gtest|\.cmake$", p)]
    c.check(not unwanted, "no tests, benchmarks, headers or static libraries", str(unwanted))
    active = [p for p in paths if p.startswith("/etc/systemd")]
    c.check(not active, "no drop-in active by default", str(active))

    # Control fields.
    fields = {}
    for name in ("Package", "Version", "Architecture", "Depends"):
        fields[name] = run(["dpkg-deb", "-f", args.deb, name]).stdout.strip()
    arch = run(["dpkg", "--print-architecture"]).stdout.strip()
    c.check(fields["Package"] == "candp2", "Package: candp2", fields["Package"])
    c.check(fields["Version"] == args.version + "-1", "Version: %s-1" % args.version,
            fields["Version"])
    c.check(fields["Architecture"] == arch, "Architecture: " + arch, fields["Architecture"])
    depends = [d.strip().split()[0] for d in fields["Depends"].split(",") if d.strip()]
    for lib in ("libc6", "libstdc++6", "libmodbus5", "libmicrohttpd12"):
        c.check(lib in depends, "Depends names " + lib, fields["Depends"])
    c.check("libsystemd0" not in depends, "Depends does not name libsystemd0", fields["Depends"])
    for prefix in ("libspdlog", "libfmt"):
        c.check(any(d.startswith(prefix) for d in depends), "Depends names %s*" % prefix,
                fields["Depends"])
    c.check(all(re.search(r"\(>= [^)]+\)", d) for d in fields["Depends"].split(",")
                if "libc6" in d), "libc6 with a minimum version (dpkg-shlibdeps)",
            fields["Depends"])

    with tempfile.TemporaryDirectory(prefix="candp2-deb-") as tmp:
        ctrl = os.path.join(tmp, "DEBIAN")
        run(["dpkg-deb", "-e", args.deb, ctrl])
        with open(os.path.join(ctrl, "conffiles")) as f:
            conffiles = f.read().split()
        c.check(conffiles == ["/etc/candp2/candp2d.json"], "conffiles: /etc/candp2/candp2d.json",
                str(conffiles))
        for script in ("postinst", "prerm", "postrm"):
            p = os.path.join(ctrl, script)
            ok = os.access(p, os.X_OK) and run(["sh", "-n", p]).returncode == 0
            c.check(ok, script + " is an executable, valid sh script")

        # lintian.
        r = run(["lintian", "--fail-on", "error,warning", args.deb])
        c.check(r.returncode == 0, "lintian exit 0", r.stdout + r.stderr)

        # The installed tree.
        root = os.path.join(tmp, "root")
        run(["dpkg-deb", "-x", args.deb, root])
        candp2d = os.path.join(root, "usr/bin/candp2d")
        r = run([candp2d, "--version"])
        c.check(r.returncode == 0 and re.fullmatch(
            r"candp2d %s \(revision \S+\)\n" % re.escape(args.version), r.stdout),
            "installed candp2d --version", repr(r.stdout + r.stderr))
        config = os.path.join(root, "etc/candp2/candp2d.json")
        r = run([candp2d, "--check", "--config", config])
        c.check(r.returncode == 0 and "configuration OK" in r.stdout,
                "installed candp2d --check --config <root>/etc/candp2/candp2d.json",
                r.stdout + r.stderr)
        with open(config) as f:
            cfg = json.load(f)
        c.check(cfg.get("state_file") == "/var/lib/candp2/state.json",
                "state_file in the unit's StateDirectory", str(cfg.get("state_file")))
        with open(os.path.join(root, "usr/share/candp2/examples/demo.json")) as f:
            demo = json.load(f)
        del cfg["state_file"]
        c.check(cfg == demo, "the installed configuration is the demo plus state_file")
        r = run([os.path.join(root, "usr/bin/candp2"), "gsd", "-q",
                 os.path.join(root, "usr/share/candp2/gsd/CDPS04A4.GSD")])
        c.check(r.returncode == 0, "installed candp2 gsd on the installed GSD", r.stdout + r.stderr)
        r = run([os.path.join(root, "usr/bin/candp2-drive"), "--version"])
        c.check(r.returncode == 0 and r.stdout.startswith("candp2-drive " + args.version),
                "installed candp2-drive --version", r.stdout + r.stderr)

        two_instances(c, root)

    print("%d failed" % c.failed if c.failed else "deb package test passed")
    return 1 if c.failed else 0


def free_ports(n):
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def modbus_answers(port, unit, deadline):
    """Reads input register 8192 (the status block, docs/modbus.md) of `unit`; True on a
    normal answer before `deadline`."""
    request = struct.pack(">HHHBBHH", 1, 0, 6, unit, 4, 8192, 1)
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=2) as s:
                s.sendall(request)
                answer = s.recv(64)
                return len(answer) >= 9 and answer[7] == 4
        except OSError:
            time.sleep(0.1)
    return False


def two_instances(c, root):
    """Runs the template's ExecStart for two instances, each on its own configuration."""
    with open(os.path.join(root, "lib/systemd/system/candp2d@.service")) as f:
        exec_start = re.search(r"^ExecStart=(.*)$", f.read(), re.M).group(1).split()
    with open(os.path.join(root, "usr/share/candp2/examples/demo.json")) as f:
        demo = json.load(f)
    procs, ports = [], {}
    try:
        for instance in ("line1", "line2"):
            modbus, http, socketcand = free_ports(3)
            cfg = json.loads(json.dumps(demo))
            cfg["modbus"]["listen"] = "127.0.0.1:%d" % modbus
            cfg["http"]["listen"] = "127.0.0.1:%d" % http
            cfg["buses"]["can0"]["socketcand"] = "127.0.0.1:%d" % socketcand
            with open(os.path.join(root, "etc/candp2/%s.json" % instance), "w") as f:
                json.dump(cfg, f)
            argv = [os.path.join(root, a.lstrip("/")) if a.startswith("/") else a
                    for a in (w.replace("%i", instance) for w in exec_start)]
            procs.append(subprocess.Popen(argv, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL))
            ports[instance] = modbus
        deadline = time.monotonic() + 20
        for instance, port in ports.items():
            c.check(modbus_answers(port, 3, deadline),
                    "template instance %s runs /etc/candp2/%s.json and answers Modbus on %d"
                    % (instance, instance, port))
        c.check(all(p.poll() is None for p in procs), "both instances still run side by side")
    finally:
        for p in procs:
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()


if __name__ == "__main__":
    sys.exit(main())
