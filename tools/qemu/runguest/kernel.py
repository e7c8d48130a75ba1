"""The Debian kernel the guest boots (an extracted PVH vmlinux when possible) and the CAN
modules copied into the image."""

from __future__ import annotations

import bz2
import glob
import gzip
import lzma
import os
import re
import shutil
import struct
import subprocess
import tempfile
import zlib

from .common import HarnessError, log
from .cpio import Layer, sha256_file

# Kernel modules loaded in every guest. Required ones must exist; optional ones are added when the
# installed kernel ships them (module names as in modules.dep, '-' and '_' are equivalent).
REQUIRED_MODULES = ["can", "can-raw", "vcan"]
OPTIONAL_MODULES = ["can-bcm", "can-gw", "can-isotp", "vxcan"]

# --sja1000: QEMU's CAN bus emulation (docs/system/devices/can.rst of QEMU) with two Kvaser PCI
# boards (one SJA1000 each) on one emulated bus, driven by the guest kernel's real drivers.
SJA1000_MODULES = ["can-dev", "sja1000", "kvaser-pci"]
SJA1000_QEMU_ARGS = ["-object", "can-bus,id=cb0",
                     "-device", "kvaser_pci,canbus=cb0", "-device", "kvaser_pci,canbus=cb0"]
SJA1000_IFACES = ["can0", "can1"]


def version_key(v: str) -> list:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", v)]


def find_kernel(args) -> tuple[str, str]:
    """Returns (vmlinuz path, module directory) of the Debian kernel to boot."""
    if args.kernel_version:
        versions = [args.kernel_version]
    else:
        # Newest module directory that has its /boot/vmlinuz (the host's own running kernel may
        # have modules without a bootable image in /boot).
        versions = sorted((os.path.basename(d) for d in glob.glob("/lib/modules/*")
                           if os.path.isfile(os.path.join(d, "modules.dep"))),
                          key=version_key, reverse=True)
        bootable = [v for v in versions if os.path.exists(f"/boot/vmlinuz-{v}")]
        versions = bootable if bootable or not args.kernel else versions
    if not versions:
        raise HarnessError("no kernel with modules found: install linux-image-amd64 "
                           "(needs /boot/vmlinuz-<version> and /lib/modules/<version>/)")
    version = versions[0]
    moddir = f"/lib/modules/{version}"
    kernel = args.kernel or f"/boot/vmlinuz-{version}"
    if not os.path.isfile(os.path.join(moddir, "modules.dep")):
        raise HarnessError(f"{moddir}/modules.dep missing: install linux-image-amd64")
    if not os.path.isfile(kernel):
        raise HarnessError(f"kernel {kernel} missing: install linux-image-amd64")
    if not os.access(kernel, os.R_OK):
        raise HarnessError(f"cannot read {kernel} (permission denied; some distributions install "
                           f"it mode 0600: chmod 0644 it or pass --kernel)")
    return kernel, moddir


def _elf_has_pvh_note(data: bytes) -> bool:
    """True when an ELF64 vmlinux carries XEN_ELFNOTE_PHYS32_ENTRY (QEMU can boot it via PVH)."""
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        return False
    phoff, = struct.unpack_from("<Q", data, 0x20)
    phentsize, phnum = struct.unpack_from("<HH", data, 0x36)
    for i in range(phnum):
        p_type, _flags, p_offset, _vaddr, _paddr, p_filesz = struct.unpack_from(
            "<IIQQQQ", data, phoff + i * phentsize)
        if p_type != 4:  # PT_NOTE
            continue
        pos, end = p_offset, p_offset + p_filesz
        while pos + 12 <= end:
            namesz, descsz, ntype = struct.unpack_from("<III", data, pos)
            name = data[pos + 12:pos + 12 + namesz].rstrip(b"\0")
            if name == b"Xen" and ntype == 18:  # XEN_ELFNOTE_PHYS32_ENTRY
                return True
            pos += 12 + (namesz + 3) // 4 * 4 + (descsz + 3) // 4 * 4
    return False


def _bzimage_payload(data: bytes) -> bytes:
    """Decompresses the vmlinux ELF inside a bzImage (Linux boot protocol >= 2.08)."""
    if data[0x202:0x206] != b"HdrS" or struct.unpack_from("<H", data, 0x206)[0] < 0x208:
        raise ValueError("not a bzImage with boot protocol 2.08+")
    setup_sects = data[0x1F1] or 4
    offset, length = struct.unpack_from("<II", data, 0x248)
    payload = data[(setup_sects + 1) * 512 + offset:][:length]
    if payload.startswith(b"\xfd7zXZ\0"):
        return lzma.LZMADecompressor(format=lzma.FORMAT_XZ).decompress(payload)
    if payload.startswith(b"\x1f\x8b"):
        return zlib.decompressobj(wbits=31).decompress(payload)
    if payload.startswith(b"\x5d\x00\x00"):
        return lzma.LZMADecompressor(format=lzma.FORMAT_ALONE).decompress(payload)
    if payload.startswith(b"BZh"):
        return bz2.BZ2Decompressor().decompress(payload)
    if payload.startswith(b"\x28\xb5\x2f\xfd") and shutil.which("zstd"):
        # The build appends the uncompressed size (4 bytes) after the zstd frame.
        res = subprocess.run(["zstd", "-dc"], input=payload[:-4], capture_output=True, timeout=120)
        if res.returncode == 0:
            return res.stdout
    raise ValueError("unsupported kernel compression")


def prepare_kernel(kernel: str, cache_dir: str, allow_pvh: bool) -> tuple[str, str]:
    """Returns (image for -kernel, how). Booting the bzImage makes the TCG guest decompress the
    kernel itself (about 5 s); an uncompressed vmlinux with a PVH entry note skips that and the
    real-mode setup. The vmlinux is extracted once per kernel content and cached."""
    if not allow_pvh:
        return kernel, "bzImage"
    digest = sha256_file(kernel)
    path = os.path.join(cache_dir, f"vmlinux-{digest[:32]}")
    if os.path.exists(path):
        os.utime(path)
        return path, "PVH, cached vmlinux"
    with open(kernel, "rb") as f:
        data = f.read()
    try:
        vmlinux = _bzimage_payload(data)
    except (ValueError, lzma.LZMAError, zlib.error, OSError, struct.error) as ex:
        log(f"note: cannot extract vmlinux from {kernel} ({ex}); booting the bzImage (slower)")
        return kernel, "bzImage"
    if not _elf_has_pvh_note(vmlinux):
        log(f"note: {kernel} has no PVH entry (CONFIG_PVH); booting the bzImage (slower)")
        return kernel, "bzImage"
    fd, tmp = tempfile.mkstemp(prefix=".vmlinux-", dir=cache_dir)
    with os.fdopen(fd, "wb") as f:
        f.write(vmlinux)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)
    for old in sorted(glob.glob(os.path.join(cache_dir, "vmlinux-*")),
                      key=lambda p: os.stat(p).st_mtime, reverse=True)[2:]:
        os.unlink(old)
    return path, "PVH, vmlinux extracted"


def _modname(rel: str) -> str:
    base = os.path.basename(rel)
    base = re.sub(r"\.ko(\.(xz|zst|gz))?$", "", base)
    return base.replace("-", "_")


def read_module(path: str) -> bytes:
    """Module contents, decompressed on the host (busybox insmod cannot unpack .ko.xz/.ko.zst)."""
    with open(path, "rb") as f:
        raw = f.read()
    if path.endswith(".ko"):
        return raw
    if path.endswith(".ko.xz"):
        return lzma.decompress(raw)
    if path.endswith(".ko.gz"):
        return gzip.decompress(raw)
    if path.endswith(".ko.zst"):
        if not shutil.which("zstd"):
            raise HarnessError(f"{path} is zstd-compressed: install the zstd package")
        res = subprocess.run(["zstd", "-dc", path], capture_output=True, timeout=60)
        if res.returncode != 0:
            raise HarnessError(f"zstd -d {path} failed: {res.stderr.decode(errors='replace')}")
        return res.stdout
    raise HarnessError(f"unknown module format: {path}")


def add_modules(layer: Layer, moddir: str, extra: list[str]) -> None:
    """Copies the CAN modules and their dependencies; writes /etc/candp2/modules (load order)."""
    deps: dict[str, tuple[str, list[str]]] = {}
    with open(os.path.join(moddir, "modules.dep")) as f:
        for line in f:
            if ":" not in line:
                continue
            mod, rest = line.split(":", 1)
            deps[_modname(mod)] = (mod.strip(), rest.split())
    builtin = set()
    bpath = os.path.join(moddir, "modules.builtin")
    if os.path.exists(bpath):
        with open(bpath) as f:
            builtin = {_modname(entry.strip()) for entry in f if entry.strip()}

    wanted = REQUIRED_MODULES + OPTIONAL_MODULES + extra
    order: list[str] = []  # relative paths, dependencies first

    def visit(rel: str, chain: tuple) -> None:
        name = _modname(rel)
        if rel in order:
            return
        if name in chain:
            raise HarnessError(f"module dependency cycle: {' -> '.join(chain + (name,))}")
        if name not in deps:
            raise HarnessError(f"{rel} (needed by {chain[-1]}) missing from modules.dep")
        for dep in reversed(deps[name][1]):  # modprobe loads them last-listed first
            visit(dep, chain + (name,))
        order.append(rel)

    for m in wanted:
        name = m.replace("-", "_")
        if name in deps:
            visit(deps[name][0], ())
        elif name in builtin:
            continue  # built into the kernel, nothing to load
        elif m in OPTIONAL_MODULES:
            continue
        else:
            raise HarnessError(f"kernel module {m} not found in {moddir}/modules.dep")

    version = os.path.basename(moddir)
    load_paths, dep_lines = [], []
    for rel in order:
        guest_rel = re.sub(r"\.ko\.(xz|zst|gz)$", ".ko", rel)
        guest = f"/lib/modules/{version}/{guest_rel}"
        layer.add_data(guest, read_module(os.path.join(moddir, rel)))
        load_paths.append(guest)
        dep_rels = [re.sub(r"\.ko\.(xz|zst|gz)$", ".ko", d) for d in deps[_modname(rel)][1]]
        dep_lines.append(f"{guest_rel}: {' '.join(dep_rels)}".rstrip())
    # A modules.dep subset so `modprobe NAME` also works inside the guest for the copied modules.
    layer.add_data(f"/lib/modules/{version}/modules.dep", ("\n".join(dep_lines) + "\n").encode())
    layer.add_data("/etc/candp2/modules", ("\n".join(load_paths) + "\n").encode())
