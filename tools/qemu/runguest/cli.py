"""The command line of run-guest and main(): image, boot, report."""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import sys
import tarfile
import tempfile
import time

from .common import EXIT_HARNESS, EXIT_TIMEOUT, PROG, HarnessError, log
from .cpio import cached_layer, prune_cache
from .image import (IPROUTE2_GUEST, KERNEL_CMDLINE, build_base_layer, build_extra_layer,
                    build_run_layer)
from .kernel import SJA1000_MODULES, SJA1000_QEMU_ARGS, find_kernel, prepare_kernel
from .qemu import RunResult, extract_out, run_qemu


def default_cache_dir() -> str:
    env = os.environ.get("CANDP2_QEMU_CACHE")
    if env:
        return env
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "candp2-qemu")


class Parser(argparse.ArgumentParser):
    def error(self, message):  # usage errors are harness errors, not a guest exit code
        self.print_usage(sys.stderr)
        log(f"error: {message}")
        sys.exit(EXIT_HARNESS)


def parse_args(argv: list[str]):
    p = Parser(
        prog=PROG,
        description="Boot the Debian kernel in QEMU (TCG) with vcan0 up and run a guest script. "
        "Exits with the script's exit code; 124 = timeout, 125 = harness/boot failure.",
        epilog="Arguments after -- are passed to the guest script.")
    p.add_argument("--script", required=True, help="shell script run in the guest (busybox ash)")
    p.add_argument("--bin", action="append", default=[], metavar="PATH[:DEST]",
                   help="host binary to copy with its shared libraries "
                   "(default DEST /usr/local/bin/<name>); repeatable")
    p.add_argument("--file", action="append", default=[], metavar="SRC:DEST",
                   help="host file to copy to guest path DEST; repeatable")
    p.add_argument("--module", action="append", default=[], metavar="NAME",
                   help="extra kernel module to load (with dependencies); repeatable")
    p.add_argument("--out-dir", metavar="DIR",
                   help="copy what the guest script leaves in /out to DIR on the host")
    p.add_argument("--timeout", type=float,
                   default=float(os.environ.get("CANDP2_QEMU_TIMEOUT", "120")),
                   help="overall limit in seconds from QEMU start (default 120)")
    p.add_argument("--memory", default="1G", help="guest RAM (default 1G)")
    p.add_argument("--smp", type=int, default=1, help="guest CPUs (default 1)")
    p.add_argument("--kernel", help="kernel image (default /boot/vmlinuz-<newest version>)")
    p.add_argument("--kernel-version", help="module directory /lib/modules/<version> to use")
    p.add_argument("--no-pvh", action="store_true",
                   help="boot the compressed bzImage instead of the extracted vmlinux (slower)")
    p.add_argument("--sja1000", action="store_true",
                   help="two emulated SJA1000 controllers (kvaser_pci) on one QEMU CAN bus: the "
                   "guest gets can0 and can1 (down) and iproute2's ip as " + IPROUTE2_GUEST)
    p.add_argument("--append", default="", help="extra kernel command line arguments")
    p.add_argument("--qemu-arg", action="append", default=[], metavar="ARG",
                   help="extra QEMU argument, e.g. --qemu-arg=-nic --qemu-arg=user; repeatable")
    p.add_argument("--cache-dir", default=default_cache_dir(),
                   help="initramfs layer cache (default $CANDP2_QEMU_CACHE or "
                   "~/.cache/candp2-qemu)")
    p.add_argument("--console-log", metavar="FILE", help="also write the console output to FILE")
    p.add_argument("--quiet", action="store_true",
                   help="do not echo the guest console to stdout")
    p.add_argument("--qemu", default="qemu-system-x86_64", help="QEMU binary")
    if "--" in argv:
        i = argv.index("--")
        args = p.parse_args(argv[:i])
        args.script_args = argv[i + 1:]
    else:
        args = p.parse_args(argv)
        args.script_args = []
    return args


def use_sja1000(args) -> None:
    """--sja1000: the CAN bus emulation, the SJA1000 driver modules and iproute2's ip."""
    args.module = SJA1000_MODULES + args.module
    args.qemu_arg = SJA1000_QEMU_ARGS + args.qemu_arg
    ip = shutil.which("ip", path="/usr/sbin:/sbin:/usr/bin:/bin")
    if not ip or not os.path.realpath(ip).endswith("/ip") or "busybox" in os.path.realpath(ip):
        raise HarnessError("iproute2's ip not found (--sja1000 needs it for CAN bit timing): "
                           "install iproute2")
    args.bin = [f"{ip}:{IPROUTE2_GUEST}"] + args.bin


@dataclasses.dataclass
class Image:
    kernel: str  # for -kernel
    boot_how: str  # "PVH, cached vmlinux", "bzImage", ...
    layers: list[str]  # cached cpio files, concatenated in this order
    base_hit: bool
    extra_hit: bool


def build_image(args) -> Image:
    """The kernel to boot and the cached base and extra layers (built when their content is new)."""
    kernel, moddir = find_kernel(args)
    try:
        os.makedirs(args.cache_dir, exist_ok=True)
    except OSError as ex:
        raise HarnessError(f"cannot create cache directory {args.cache_dir}: {ex.strerror}")
    boot_image, boot_how = prepare_kernel(kernel, args.cache_dir, not args.no_pvh)
    base_path, base_hit = cached_layer(build_base_layer(moddir, args.module), args.cache_dir,
                                       "base")
    layers = [base_path]
    extra_hit = True
    if args.bin or args.file:
        extra_path, extra_hit = cached_layer(build_extra_layer(args), args.cache_dir, "extra")
        layers.append(extra_path)
    prune_cache(args.cache_dir)
    return Image(boot_image, boot_how, layers, base_hit, extra_hit)


def boot(args, qemu: str, image: Image, run_layer: bytes,
         t_start: float) -> tuple[RunResult, float]:
    """Writes the per-run initrd, runs QEMU; returns the result and the image time."""
    fd, initrd = tempfile.mkstemp(prefix="candp2-qemu-initrd-", suffix=".cpio")

    def drop_initrd() -> None:
        if os.path.exists(initrd):
            os.unlink(initrd)

    console_log = None
    try:
        with os.fdopen(fd, "wb") as out:
            for path in image.layers:
                with open(path, "rb") as f:
                    shutil.copyfileobj(f, out, 1 << 20)
            out.write(run_layer)
        t_image = time.monotonic() - t_start

        append = KERNEL_CMDLINE + (" " + args.append if args.append else "")
        cmd = [qemu, "-accel", "tcg", "-nodefaults", "-no-user-config", "-nographic",
               "-no-reboot", "-m", args.memory, "-smp", str(args.smp), "-serial", "stdio",
               "-monitor", "none", "-nic", "none", "-kernel", image.kernel, "-initrd", initrd,
               "-append", append] + args.qemu_arg
        console_log = open(args.console_log, "w") if args.console_log else None
        # The initrd copy is deleted as soon as QEMU has loaded it, so even a harness killed with
        # SIGKILL (QEMU follows it through PDEATHSIG) leaves nothing behind.
        res = run_qemu(cmd, args.timeout, console_log, not args.quiet, drop_initrd)
    finally:
        drop_initrd()
        if console_log:
            console_log.close()
    return res, t_image


def report(args, res: RunResult, timing: str) -> int:
    """The summary line on stderr and the exit code of run-guest."""

    def failed(msg: str) -> None:
        log(f"FAILED: {msg} ({timing})")
        if res.tail:
            if args.quiet:
                log("last console lines:\n  " + "\n  ".join(res.tail))
            else:
                log(f"last console line: {res.tail[-1]}")

    if res.state.startswith("timeout:"):
        where = {"booting": "while the guest was booting", "script": "while the guest script ran",
                 "finished": "after the guest script ended"}[res.state.split(":", 1)[1]]
        failed(f"timeout after {args.timeout:g} s {where}; QEMU killed")
        return EXIT_TIMEOUT
    if res.setup_failure:
        failed(f"guest setup failed: {res.setup_failure}")
        return EXIT_HARNESS
    if res.exit_code is None:
        if res.state == "booting":
            failed("QEMU exited before the guest script started (kernel did not boot or init "
                   "failed; see the console output)")
        else:
            failed("QEMU exited before the guest reported the script's exit code (guest kernel "
                   "panic, or the script powered the guest off?)")
        return EXIT_HARNESS
    if res.shutdown_killed:
        log("warning: the guest did not power off within 15 s after the script ended; QEMU killed")
    log(f"guest script exit code {res.exit_code}; {timing}")
    return res.exit_code


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    t_start = time.monotonic()
    if args.sja1000:
        use_sja1000(args)
    run_layer = build_run_layer(args)  # first: a missing script is reported before any work
    qemu = shutil.which(args.qemu)
    if not qemu:
        raise HarnessError(f"{args.qemu} not found: install qemu-system-x86")
    image = build_image(args)
    res, t_image = boot(args, qemu, image, run_layer, t_start)

    if res.out_b64 and args.out_dir:
        try:
            n = extract_out(res.out_b64, args.out_dir)
            log(f"copied {n} file(s) from guest /out to {args.out_dir}")
        except (ValueError, EOFError, OSError, tarfile.TarError) as ex:
            raise HarnessError(f"could not unpack guest /out: {ex}")

    def secs(t):
        return f"{t:.1f} s" if t is not None else "n/a"

    boot_s = res.t_begin - (t_start + t_image) if res.t_begin else None
    script = res.t_end - res.t_begin if res.t_end and res.t_begin else None
    uptime = f" (guest uptime {res.guest_uptime_begin} s)" if res.guest_uptime_begin else ""
    timing = (f"image {secs(t_image)} ({image.boot_how}, base layer "
              f"{'cached' if image.base_hit else 'built'}"
              f"{'' if image.extra_hit else ', extra layer built'}), boot-to-script "
              f"{secs(boot_s)}{uptime}, script {secs(script)}, total "
              f"{secs(time.monotonic() - t_start)}")
    return report(args, res, timing)
