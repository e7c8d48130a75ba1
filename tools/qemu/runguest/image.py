"""The guest image: the base layer (busybox, can-utils, CAN modules, /init), the extra layer
(--bin, --file) and the per-run layer (the script and its arguments)."""

from __future__ import annotations

import io
import os
import re
import shlex
import shutil
import subprocess

from . import common
from .common import HarnessError
from .cpio import Layer
from .kernel import SJA1000_IFACES, add_modules

# can-utils programs copied into the guest. The first three are required.
REQUIRED_CAN_UTILS = ["candump", "cansend", "canplayer"]
OPTIONAL_CAN_UTILS = [
    "cangen", "cansequence", "canbusload", "cansniffer", "cangw", "canfdtest", "canlogserver",
    "bcmserver", "log2asc", "asc2log", "log2long", "isotpsend", "isotprecv", "isotpdump",
    "isotpsniffer",
]

# iproute2's ip (BusyBox's ip cannot set CAN bit timing, and BusyBox's ash runs its own applet for
# "ip"), copied under this name.
IPROUTE2_GUEST = "/usr/local/bin/iproute2-ip"

KERNEL_CMDLINE = "console=ttyS0 quiet panic=-1"
GUEST_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"

# tools/qemu/, where guest-init.sh and guest-lib.sh live.
QEMU_DIR = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))


def init_script() -> bytes:
    """PID 1 of the guest: tools/qemu/guest-init.sh with its @NAME@ placeholders filled in."""
    path = os.path.join(QEMU_DIR, "guest-init.sh")
    try:
        with open(path) as f:
            init = f.read()
    except OSError as ex:
        raise HarnessError(f"cannot read {path}: {ex.strerror}") from None
    init = init.replace("@GUEST_PATH@", GUEST_PATH)
    for name in ("MARK_BEGIN", "MARK_END", "MARK_EXIT", "MARK_SETUP_FAILED", "MARK_OUT_BEGIN",
                 "MARK_OUT_END"):
        init = init.replace(f"@{name}@", getattr(common, name))
    return init.encode()


def ldd_paths(binaries: list[str]) -> list[str]:
    """Shared libraries (absolute paths, loader included) the given dynamic binaries need."""
    if not binaries:
        return []
    try:
        res = subprocess.run(["ldd"] + binaries, capture_output=True, text=True, timeout=60)
    except FileNotFoundError:
        raise HarnessError("ldd not found (package libc-bin)") from None
    paths: list[str] = []
    current = binaries[0]
    for line in res.stdout.splitlines():
        if len(binaries) > 1 and not line.startswith(("\t", " ")) and line.endswith(":"):
            current = line[:-1]
            continue
        line = line.strip()
        if "=> not found" in line:
            raise HarnessError(f"{current}: shared library {line.split()[0]} not found on the host")
        m = re.match(r"^(?:\S+\s+=>\s+)?(/\S+)\s+\(0x[0-9a-f]+\)$", line)
        if m and m.group(1) not in paths:
            paths.append(m.group(1))
    # ldd exits 1 when any file is static ("not a dynamic executable"); only other errors count.
    errors = [e for e in res.stderr.splitlines() if "not a dynamic executable" not in e]
    if res.returncode != 0 and errors:
        raise HarnessError(f"ldd failed: {' '.join(errors)}")
    return paths


def add_binaries(layer: Layer, binaries: list[tuple[str, str | None]]) -> None:
    """Copies host binaries (source, guest destination or None for the same path) and every
    shared library they need, at the library's host path."""
    for source, dest in binaries:
        if not os.path.isfile(source):
            raise HarnessError(f"binary {source} not found")
        if not os.access(source, os.X_OK):
            raise HarnessError(f"{source} is not executable")
        if dest is None:
            layer.add_host_path(source)
        else:
            layer.add_file(dest, source, 0o755)
    for lib in ldd_paths([source for source, _ in binaries]):
        layer.add_host_path(lib)


def build_base_layer(moddir: str, extra_modules: list[str]) -> Layer:
    layer = Layer()
    for d in ("/proc", "/sys", "/dev", "/tmp", "/run", "/root", "/mnt", "/out", "/var/log",
              "/etc/candp2", "/usr/local/bin", "/usr/local/sbin"):
        layer.add_dir(d)
    layer.entries[layer.resolve("/tmp")].mode = 0o1777
    layer.add_chr("/dev/console", 5, 1)  # the kernel opens it before /init mounts devtmpfs
    layer.add_chr("/dev/null", 1, 3, 0o666)

    busybox = shutil.which("busybox", path="/bin:/usr/bin:/sbin:/usr/sbin")
    if not busybox:
        raise HarnessError("busybox not found: install busybox-static")
    busybox = os.path.abspath(busybox)
    binaries: list[tuple[str, str | None]] = [(busybox, None)]
    res = subprocess.run([busybox, "--list-full"], capture_output=True, text=True, timeout=30)
    if res.returncode != 0:
        raise HarnessError(f"{busybox} --list-full failed")
    for applet in res.stdout.split():
        path = layer.resolve("/" + applet)
        if path != layer.resolve(busybox):
            layer.add_symlink(path, busybox)

    for tool in REQUIRED_CAN_UTILS + OPTIONAL_CAN_UTILS:
        path = shutil.which(tool, path="/usr/bin:/bin:/usr/sbin:/sbin")
        if path:
            binaries.append((path, None))
        elif tool in REQUIRED_CAN_UTILS:
            raise HarnessError(f"{tool} not found: install can-utils")
    add_binaries(layer, binaries)

    add_modules(layer, moddir, extra_modules)
    layer.add_data("/init", init_script(), 0o755)
    layer.add_file("/etc/candp2/guest-lib.sh", os.path.join(QEMU_DIR, "guest-lib.sh"), 0o644)
    layer.add_data("/etc/passwd", b"root:x:0:0:root:/root:/bin/sh\n")
    layer.add_data("/etc/group", b"root:x:0:\n")
    layer.add_data("/etc/hosts", b"127.0.0.1 localhost candp2-guest\n::1 localhost\n")
    return layer


def split_spec(spec: str, what: str) -> tuple[str, str | None]:
    if ":" in spec:
        src, dest = spec.split(":", 1)
        if not dest.startswith("/"):
            raise HarnessError(f"{what} {spec}: destination must be an absolute guest path")
        return src, dest
    return spec, None


def build_extra_layer(args) -> Layer:
    layer = Layer()
    binaries = []
    for spec in args.bin:
        src, dest = split_spec(spec, "--bin")
        binaries.append((src, dest or "/usr/local/bin/" + os.path.basename(src)))
    add_binaries(layer, binaries)
    for spec in args.file:
        src, dest = split_spec(spec, "--file")
        if dest is None:
            raise HarnessError(f"--file {spec}: expected SRC:DEST")
        layer.add_file(dest, src)
    return layer


def build_run_layer(args) -> bytes:
    layer = Layer()
    try:
        with open(args.script, "rb") as f:
            script = f.read()
    except OSError as ex:
        raise HarnessError(f"cannot read guest script {args.script}: {ex.strerror}") from None
    layer.add_data("/etc/candp2/script", script, 0o755)
    layer.add_data("/etc/candp2/args", " ".join(shlex.quote(a) for a in args.script_args).encode())
    if args.out_dir:
        layer.add_data("/etc/candp2/collect-out", b"")
    if args.sja1000:
        layer.add_data("/etc/candp2/expect-ifaces", (" ".join(SJA1000_IFACES) + "\n").encode())
    buf = io.BytesIO()
    layer.serialise(buf)
    return buf.getvalue()
