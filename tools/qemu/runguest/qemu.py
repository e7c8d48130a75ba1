"""Running QEMU: the console read line by line (markers, echo, the /out block), the time limit,
and unpacking the guest's /out."""

from __future__ import annotations

import base64
import collections
import ctypes
import dataclasses
import gzip
import io
import os
import re
import selectors
import signal
import subprocess
import sys
import tarfile
import time

from .common import (MARK_BEGIN, MARK_END, MARK_EXIT, MARK_OUT_BEGIN, MARK_OUT_END,
                     MARK_SETUP_FAILED, HarnessError, log)


def _die_with_parent() -> None:
    """Child-side: QEMU gets SIGKILL if this harness dies (e.g. killed by a ctest timeout)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except Exception:
        pass


@dataclasses.dataclass
class RunResult:
    exit_code: int | None = None
    state: str = "booting"  # booting -> script -> finished
    setup_failure: str | None = None
    t_begin: float | None = None
    t_end: float | None = None
    guest_uptime_begin: str | None = None
    shutdown_killed: bool = False  # QEMU did not exit by itself after the script reported
    tail: collections.deque = dataclasses.field(
        default_factory=lambda: collections.deque(maxlen=20))  # last console lines
    out_b64: list[str] = dataclasses.field(default_factory=list)


# Terminal control from the firmware and kernel (ESC c reset, ESC [ ... CSI sequences).
ANSI_ESCAPE = re.compile(r"\x1b(\[[0-9;?]*[ -/]*[@-~]|[@-_c])")


def run_qemu(cmd: list[str], timeout: float, console_log, echo: bool, on_output) -> RunResult:
    """Runs QEMU until it exits or the time limit; `on_output` is called once at the first console
    output (QEMU has read -kernel/-initrd by then)."""
    res = RunResult()
    t0 = time.monotonic()
    deadline = t0 + timeout
    shutdown_deadline = None
    in_out = False
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, preexec_fn=_die_with_parent)
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    pending = b""
    timed_out = False

    def emit(line: str) -> None:
        if line.strip():
            res.tail.append(line)
        if console_log:
            console_log.write(line + "\n")
        if echo:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()

    def handle(line: str) -> None:
        nonlocal in_out, shutdown_deadline
        now = time.monotonic()
        if in_out:  # base64 of the guest's /out: decoded later, not echoed
            if line.startswith(MARK_OUT_END):
                in_out = False
            else:
                res.out_b64.append(line.strip())
            return
        if res.state == "booting":
            emit(line)
            if line.startswith(MARK_BEGIN):
                res.state, res.t_begin = "script", now
                m = re.search(r"uptime=(\S+)", line)
                res.guest_uptime_begin = m.group(1) if m else None
            elif MARK_SETUP_FAILED in line:
                res.setup_failure = line.split(MARK_SETUP_FAILED, 1)[1].strip()
        elif res.state == "script":
            # A script whose output does not end in a newline leaves the marker mid-line.
            i = line.find(MARK_END + " uptime=")
            if i > 0:
                emit(line[:i])
            emit(line[max(i, 0):])
            if i >= 0:
                res.state, res.t_end = "finished", now
        elif line.startswith(MARK_OUT_BEGIN):
            in_out = True
        else:
            emit(line)
            if line.startswith(MARK_EXIT):
                try:
                    res.exit_code = int(line[len(MARK_EXIT):].strip())
                except ValueError:
                    return
                # The guest powers off now; a hanging shutdown must not fail a finished run.
                shutdown_deadline = now + 15

    try:
        while True:
            now = time.monotonic()
            limit = deadline if shutdown_deadline is None else min(deadline, shutdown_deadline)
            if now >= limit:
                timed_out = res.exit_code is None
                res.shutdown_killed = res.exit_code is not None
                break
            events = sel.select(timeout=min(1.0, limit - now))
            if not events:
                continue
            chunk = os.read(proc.stdout.fileno(), 65536)
            if not chunk:
                break  # QEMU exited
            if on_output:
                on_output()
                on_output = None
            pending += chunk
            *lines, pending = pending.split(b"\n")
            for raw in lines:
                handle(ANSI_ESCAPE.sub("", raw.decode("utf-8", errors="replace")).rstrip("\r"))
        if pending:
            handle(ANSI_ESCAPE.sub("", pending.decode("utf-8", errors="replace")).rstrip("\r"))
    finally:
        sel.close()
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        proc.stdout.close()
    if timed_out:
        res.state = "timeout:" + res.state
    return res


def extract_out(b64_lines: list[str], out_dir: str) -> int:
    """Unpacks the guest's /out (base64 of a tar.gz) into out_dir; returns the number of files."""
    data = gzip.decompress(base64.b64decode("".join(b64_lines)))
    os.makedirs(out_dir, exist_ok=True)
    count = 0
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:") as tar:
        for m in tar.getmembers():
            name = os.path.normpath(m.name)
            if name == ".":
                continue
            if name.startswith("/") or name.startswith(".."):
                raise HarnessError(f"guest /out contains a bad path: {m.name}")
            if not (m.isfile() or m.isdir()):
                log(f"skipping {m.name} from guest /out (not a file or directory)")
                continue
            m.name = name
            m.mode = 0o755 if m.isdir() else 0o644
            tar.extract(m, out_dir, set_attrs=False)
            count += m.isfile()
    return count
