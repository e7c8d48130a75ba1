#!/usr/bin/python3
"""Smoke test of what `tools/setup.sh run` builds and starts, run by
`tools/setup.sh test` on the run command's own Release build:

  1. `candp2d --version` names the version and the source revision;
  2. candp2d without --config (the built-in default, config/demo.json) starts and listens on the
     fixed Modbus port 1502 (it says READY=1 on a NOTIFY_SOCKET of ours, with that address);
  3. the README's mbpoll walk-through (section "The demo"), read from README.md itself so the two
     cannot drift apart, gives its documented answer (`0xA866 0x2600` in input registers 0..1 once
     the drive's ramp is done);
  4. SIGTERM stops it cleanly: exit status 0 and "stopped" in its log.

Port 1502 (and socketcand's 29536) are fixed by the built-in default: when one is busy the test
fails at once with a message saying so, instead of hanging. Every wait has a deadline. The
status registers come from the daemon's own map (`--print-modbus-map --json`, read by the candp2
package in python/).

  run_smoke.py --candp2d build-release/bin/candp2d
"""

import argparse
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python"))
from candp2 import RegisterMap  # noqa: E402  (python/: the register map, read from candp2d)
from candp2._notify import NotifySocket  # noqa: E402

MODBUS_PORT = 1502       # config/demo.json "modbus.listen"
SOCKETCAND_PORT = 29536  # config/demo.json "buses.can0.socketcand"
UNIT = 3


def fail(msg):
    raise SystemExit("FAIL: " + msg)


def port_free(port):
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
            return True
        except OSError:
            return False


def readme_walkthrough():
    """The demo section's mbpoll commands and the answer it documents."""
    with open(os.path.join(ROOT, "README.md")) as f:
        text = f.read()
    section = text.split("## The demo", 1)[1].split("\n## ", 1)[0]
    m = re.search(r'^\s*M="([^"]+)"\s*$', section, re.M)
    if not m:
        fail('README "The demo": no M="mbpoll ..." line')
    commands = [re.sub(r"\s+#.*$", "", line.strip()) for line in section.splitlines()
                if line.strip().startswith("$M ")]
    answer = re.search(r"The last read shows `((?:0x[0-9A-F]{4} ?)+)`", section)
    if len(commands) < 2 or not answer:
        fail('README "The demo": expected $M commands and "The last read shows `0x....`"')
    prefix = m.group(1).split()
    argv = [prefix + c.split()[1:] for c in commands]
    return argv[:-1], argv[-1], answer.group(1).split()


def mbpoll(argv, timeout=10):
    r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0 or "failed" in r.stdout.lower() + r.stderr.lower():
        fail("%s: exit %d\n%s%s" % (" ".join(argv), r.returncode, r.stdout, r.stderr))
    return r.stdout


def registers(output):
    """mbpoll's "[N]: 	0xABCD" lines as ["0xABCD", ...] (hex tables) or ints."""
    return [v for _, v in re.findall(r"^\[(\d+)\]:\s+(\S+)", output, re.M)]


def tx_frames(base, regs):
    """Status field tx_frames of unit 3: CAN frames the gateway sent (docs/modbus.md)."""
    field = regs.fields["tx_frames"]
    out = mbpoll(base + ["-r", str(field.register), "-c", str(field.registers), "-t", "3",
                         "127.0.0.1"])
    hi, lo = (int(v) for v in registers(out))
    return (hi << 16) | lo


def wait_ready(notify, proc, timeout=10.0):
    """Waits for READY=1 on our NOTIFY_SOCKET (docs/daemon.md "systemd"); its Modbus address."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        fields = notify.receive(0.1)
        if fields and fields.get("READY") == "1":
            return fields.get("X_CANDP2_MODBUS")
        if proc.poll() is not None:
            fail("candp2d exited with %s before READY=1" % proc.returncode)
    fail("no READY=1 from candp2d within %.0f s" % timeout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    args = ap.parse_args()
    writes, read, answer = readme_walkthrough()
    base = writes[0][:writes[0].index("-r")]  # "mbpoll -m tcp -p 1502 -a 3 -0 -1"
    regs = RegisterMap.from_binary(args.candp2d)
    dp_state = str(regs.fields["dp_state"].register)

    version = subprocess.run([args.candp2d, "--version"], capture_output=True, text=True,
                             timeout=10)
    if version.returncode != 0 or not re.fullmatch(r"candp2d \d+\.\d+\.\d+ \(revision \S+\)\n",
                                                   version.stdout):
        fail("--version: %r (exit %d)" % (version.stdout, version.returncode))
    print("version:", version.stdout.strip())

    for port in (MODBUS_PORT, SOCKETCAND_PORT):
        if not port_free(port):
            fail("port %d on 127.0.0.1 is busy (another candp2d?); the built-in default needs it"
                 % port)

    with tempfile.TemporaryDirectory(prefix="candp2-smoke-") as tmp:
        log_path = os.path.join(tmp, "candp2d.log")
        notify = NotifySocket(os.path.join(tmp, "notify"))
        env = dict(os.environ, NOTIFY_SOCKET=notify.path)
        with open(log_path, "w") as log:
            proc = subprocess.Popen([args.candp2d], stdout=log, stderr=subprocess.STDOUT,
                                    env=env)
        try:
            modbus = wait_ready(notify, proc)
            if modbus != "127.0.0.1:%d" % MODBUS_PORT:
                fail("READY=1 names Modbus %s, the built-in default is 127.0.0.1:%d"
                     % (modbus, MODBUS_PORT))
            # The gateway reaches Data_Exch a few master cycles after the start.
            data_exch = str(regs.values["dp_state"].index("Data_Exch"))
            end = time.monotonic() + 10
            while registers(mbpoll(base + ["-r", dp_state, "-t", "3", "127.0.0.1"])) != [
                    data_exch]:
                if time.monotonic() > end:
                    fail("gateway never reached Data_Exch")
                time.sleep(0.05)
            for argv in writes:
                # Each write is a new command; wait until the slot has sent it (its Tx counter
                # moves) before the next one replaces it (slots send on change, manual §3.2.3).
                before = tx_frames(base, regs)
                print("$", " ".join(argv))
                mbpoll(argv)
                end = time.monotonic() + 5
                while tx_frames(base, regs) == before:
                    if time.monotonic() > end:
                        fail("%s never reached the CAN bus" % " ".join(argv))
                    time.sleep(0.02)
            print("$", " ".join(read), " # until", " ".join(answer))
            end = time.monotonic() + 10
            while True:
                got = registers(mbpoll(read))[:len(answer)]
                if [g.upper().replace("0X", "0x") for g in got] == answer:
                    break
                if time.monotonic() > end:
                    fail("README's read shows %s, documented %s" % (got, answer))
                time.sleep(0.05)
            print("read:", " ".join(got))

            proc.send_signal(signal.SIGTERM)
            try:
                rc = proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                fail("candp2d did not stop within 10 s of SIGTERM")
            with open(log_path) as f:
                text = f.read()
            if rc != 0:
                fail("exit status %d after SIGTERM\n%s" % (rc, text))
            if not re.search(r"\[candp2d\] stopped$", text, re.M):
                fail("no \"stopped\" line in the log\n" + text)
            print("SIGTERM: exit 0, log says stopped")
        finally:
            notify.close()
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=10)
    print("run smoke test passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
