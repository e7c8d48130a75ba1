"""initramfs layers: cpio "newc" archives built in memory, keyed by their content, cached."""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import os
import stat
import tempfile

from .common import IMAGE_FORMAT, HarnessError


@dataclasses.dataclass
class Entry:
    kind: str  # "dir", "file", "symlink", "chr"
    mode: int = 0o755
    source: str | None = None  # host file for "file" entries (read when serialised)
    data: bytes | None = None  # inline content for "file" entries
    target: str | None = None  # "symlink"
    rdev: tuple[int, int] = (0, 0)  # "chr"
    digest: str = ""


_digests: dict[tuple, str] = {}


def sha256_file(path: str) -> str:
    st = os.stat(path)
    memo = (os.path.realpath(path), st.st_size, st.st_mtime_ns, st.st_ino)
    if memo in _digests:
        return _digests[memo]
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    _digests[memo] = h.hexdigest()
    return _digests[memo]


class Layer:
    """One cpio archive. Several layers are concatenated into the initrd; later ones override files.

    Every layer carries the host's top-level symlinks (/bin -> usr/bin on merged-/usr systems) so
    paths resolve the same way inside the guest as on the host.
    """

    def __init__(self) -> None:
        self.entries: dict[str, Entry] = {}
        for top in ("bin", "sbin", "lib", "lib32", "lib64", "libx32"):
            host = "/" + top
            if os.path.islink(host):
                self.entries[host] = Entry("symlink", 0o777, target=os.readlink(host))

    # -- guest-side path handling

    def resolve(self, path: str, depth: int = 0) -> str:
        """Resolves symlinks that this layer itself defines (e.g. /bin/sh -> /usr/bin/sh)."""
        if depth > 16:
            raise HarnessError(f"symlink loop while resolving {path} in the image")
        parts = [p for p in path.split("/") if p]
        cur = ""
        for i, comp in enumerate(parts):
            cur = cur + "/" + comp
            e = self.entries.get(cur)
            if e is not None and e.kind == "symlink" and i < len(parts) - 1:
                base = e.target if e.target.startswith("/") else os.path.join(
                    os.path.dirname(cur), e.target)
                rest = "/".join(parts[i + 1:])
                return self.resolve(os.path.normpath(base + "/" + rest), depth + 1)
        return "/" + "/".join(parts)

    def add_dir(self, path: str, mode: int = 0o755) -> str:
        path = self.resolve(path)
        if path == "/":
            return path
        e = self.entries.get(path)
        if e is not None and e.kind == "symlink":
            return self.add_dir(self.resolve(path + "/."))
        if e is not None:
            if e.kind != "dir":
                raise HarnessError(f"image path {path} is a {e.kind}, cannot be a directory")
            return path
        self.add_dir(os.path.dirname(path))
        self.entries[path] = Entry("dir", mode)
        return path

    def _parent(self, path: str) -> str:
        path = self.resolve(path)
        self.add_dir(os.path.dirname(path))
        return path

    def add_data(self, path: str, data: bytes, mode: int = 0o644) -> None:
        path = self._parent(path)
        self.entries[path] = Entry("file", mode, data=data,
                                   digest=hashlib.sha256(data).hexdigest())

    def add_file(self, path: str, source: str, mode: int | None = None) -> None:
        """Copies host file `source` (symlinks followed) to guest `path`."""
        try:
            st = os.stat(source)
        except OSError as ex:
            raise HarnessError(f"cannot read {source}: {ex.strerror}") from None
        if not stat.S_ISREG(st.st_mode):
            raise HarnessError(f"{source} is not a regular file")
        if not os.access(source, os.R_OK):
            raise HarnessError(f"cannot read {source}: permission denied")
        path = self._parent(path)
        self.entries[path] = Entry("file", mode if mode is not None else stat.S_IMODE(st.st_mode),
                                   source=source, digest=sha256_file(source))

    def add_symlink(self, path: str, target: str) -> None:
        path = self._parent(path)
        self.entries[path] = Entry("symlink", 0o777, target=target)

    def add_chr(self, path: str, major: int, minor: int, mode: int = 0o600) -> None:
        path = self._parent(path)
        self.entries[path] = Entry("chr", mode, rdev=(major, minor))

    def add_host_path(self, path: str, depth: int = 0) -> None:
        """Copies host file `path` to the same place in the guest, reproducing every symlink on the
        way (/lib64/ld-linux-x86-64.so.2 -> /usr/lib64/... -> ../lib/x86_64-linux-gnu/...)."""
        if depth > 16:
            raise HarnessError(f"symlink loop at {path}")
        path = os.path.normpath(path)
        parts = [p for p in path.split("/") if p]
        cur = ""
        for i, comp in enumerate(parts):
            cur = cur + "/" + comp
            if os.path.islink(cur):
                target = os.readlink(cur)
                if cur not in self.entries or self.entries[cur].kind != "symlink":
                    self.add_symlink(cur, target)
                base = target if target.startswith("/") else os.path.join(os.path.dirname(cur),
                                                                          target)
                rest = "/".join(parts[i + 1:])
                self.add_host_path(os.path.normpath(base + ("/" + rest if rest else "")),
                                   depth + 1)
                return
        self.add_file(path, path)

    # -- key and serialisation

    def key(self, extra: str = "") -> str:
        h = hashlib.sha256()
        h.update(IMAGE_FORMAT.encode() + b"\0" + extra.encode() + b"\0")
        for path in sorted(self.entries):
            e = self.entries[path]
            h.update(f"{path}\0{e.kind}\0{e.mode:o}\0{e.target}\0{e.rdev}\0{e.digest}\n".encode())
        return h.hexdigest()

    def serialise(self, out) -> None:
        ino = 1

        def header(name: str, mode: int, size: int, nlink: int, rdev=(0, 0)) -> None:
            nonlocal ino
            namebytes = name.encode() + b"\0"
            fields = [ino, mode, 0, 0, nlink, 0, size, 0, 0, rdev[0], rdev[1], len(namebytes), 0]
            ino += 1
            hdr = b"070701" + b"".join(b"%08X" % v for v in fields) + namebytes
            out.write(hdr + b"\0" * (-len(hdr) % 4))

        def body(data: bytes) -> None:
            out.write(data + b"\0" * (-len(data) % 4))

        # Parents before children: sorting by path gives "/a" before "/a/b".
        for path in sorted(self.entries, key=lambda p: p.split("/")):
            e = self.entries[path]
            name = path.lstrip("/")
            if e.kind == "dir":
                header(name, stat.S_IFDIR | e.mode, 0, 2)
            elif e.kind == "symlink":
                target = e.target.encode()
                header(name, stat.S_IFLNK | 0o777, len(target), 1)
                body(target)
            elif e.kind == "chr":
                header(name, stat.S_IFCHR | e.mode, 0, 1, e.rdev)
            else:
                if e.data is not None:
                    data = e.data
                else:
                    with open(e.source, "rb") as f:
                        data = f.read()
                header(name, stat.S_IFREG | e.mode, len(data), 1)
                body(data)
        header("TRAILER!!!", 0, 0, 1)
        # Pad so the next concatenated archive starts aligned; the kernel skips the zeros.
        pos = out.tell()
        out.write(b"\0" * (-pos % 512))


def cached_layer(layer: Layer, cache_dir: str, name: str, extra: str = "") -> tuple[str, bool]:
    """Returns (path, cache_hit) of the serialised layer, building it when its key is new."""
    key = layer.key(extra)
    path = os.path.join(cache_dir, f"{name}-{key[:32]}.cpio")
    if os.path.exists(path):
        os.utime(path)
        return path, True
    fd, tmp = tempfile.mkstemp(prefix=f".{name}-", dir=cache_dir)
    try:
        with os.fdopen(fd, "wb") as f:
            layer.serialise(f)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)  # atomic: parallel runs may build the same layer
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path, False


def prune_cache(cache_dir: str, keep: int = 24) -> None:
    files = sorted(glob.glob(os.path.join(cache_dir, "*.cpio")), key=lambda p: os.stat(p).st_mtime,
                   reverse=True)
    for old in files[keep:]:
        try:
            os.unlink(old)
        except OSError:
            pass
