"""Which candp2d (and candp2) to run, and where its example configurations are.

The order is the pytest plugin's (`candp2_binary`): a path given explicitly, else the one of
pytest's `--candp2d` option (the plugin sets it for the whole session), else `$CANDP2D`, else
`candp2d` on PATH (the Debian package puts it in /usr/bin), else the build tree of the source
checkout this package was imported from (`build/bin/candp2d`, then `build-release/bin/candp2d`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .errors import Candp2Error

#: Build directories of a source checkout, searched in this order (README.md, tools/setup.sh).
BUILD_DIRS = ("build", "build-release")
#: The candp2d to run when none is given (env), and where examples are looked for first.
BINARY_ENV, EXAMPLES_ENV = "CANDP2D", "CANDP2_EXAMPLES"

#: The candp2d of pytest's --candp2d option (set by the plugin), the default of find_binary().
_session_binary: str | None = None


def set_session_binary(path: str | os.PathLike[str] | None) -> None:
    """Makes `path` the candp2d find_binary() (and so example()) finds without an explicit one:
    the pytest plugin calls it with --candp2d."""
    global _session_binary
    _session_binary = None if path is None else _find("candp2d", path)


def _checkout() -> Path | None:
    """The source checkout holding this package (python/candp2/), or None when installed."""
    root = Path(__file__).resolve().parent.parent.parent
    return root if (root / "CMakeLists.txt").exists() and (root / "daemon").is_dir() else None


def _find(name: str, explicit: str | os.PathLike[str] | None) -> str:
    if explicit is not None:
        path = Path(explicit)
        if not path.is_file() or not os.access(path, os.X_OK):
            raise Candp2Error("%s: not an executable file" % path)
        return str(path.resolve())
    if name == "candp2d":
        if _session_binary is not None:
            return _session_binary
        if os.environ.get(BINARY_ENV):
            return _find(name, os.environ[BINARY_ENV])
    on_path = shutil.which(name)
    if on_path:
        return on_path
    root = _checkout()
    tried = ["%s on PATH" % name]
    if root is not None:
        for build in BUILD_DIRS:
            candidate = root / build / "bin" / name
            if candidate.is_file() and os.access(candidate, os.X_OK):
                return str(candidate)
            tried.append(str(candidate))
    raise Candp2Error("no %s found (tried %s); install the candp2 package, build it "
                      "(tools/setup.sh run) or give its path (pytest --candp2d PATH, "
                      "$%s, Daemon(binary=...))" % (name, ", ".join(tried), BINARY_ENV))


def find_binary(explicit: str | os.PathLike[str] | None = None) -> str:
    """The candp2d to run: `explicit` if given, else pytest's --candp2d, else $CANDP2D, else
    PATH, else the source checkout's build tree.

    Raises Candp2Error naming every place it looked."""
    return _find("candp2d", explicit)


def find_tool(candp2d: str | None = None, explicit: str | os.PathLike[str] | None = None) -> str:
    """The `candp2` tool (replay, validate): `explicit` if given, else the one beside `candp2d`,
    else PATH, else the build tree."""
    if explicit is None and candp2d is not None:
        beside = Path(candp2d).with_name("candp2")
        if beside.is_file() and os.access(beside, os.X_OK):
            return str(beside)
    return _find("candp2", explicit)


#: Where an installation keeps the example configurations and scenarios, under its prefix
#: (CMakeLists.txt install rules; the Debian package: /usr/share/candp2/examples).
EXAMPLES_DIR = Path("share", "candp2", "examples")


def build_source(binary: Path) -> Path | None:
    """The source tree a candp2d in a CMake build tree was built from (BUILD/bin/candp2d:
    CMAKE_HOME_DIRECTORY in BUILD/CMakeCache.txt), or None for an installed one."""
    try:
        with open(binary.parent.parent / "CMakeCache.txt", errors="replace") as f:
            for line in f:
                if line.startswith("CMAKE_HOME_DIRECTORY:"):
                    return Path(line.split("=", 1)[1].strip())
    except OSError:
        pass
    return None


def find_example(name: str, candp2d: str | os.PathLike[str] | None = None) -> Path:
    """An example configuration or scenario of candp2 ("plc-line.json",
    "scenarios/demo.json"), looked for in this order: $CANDP2_EXAMPLES/NAME; the source
    checkout's config/NAME when this package was imported from one; beside the candp2d that
    runs (`candp2d`, else the one find_binary() finds, pytest's --candp2d included):
    PREFIX/share/candp2/examples/NAME for an installed one (/usr/bin/candp2d gives
    /usr/share/candp2/examples), SOURCE/config/NAME for one in a build tree (the source tree
    its CMakeCache.txt names).

    The examples' relative file names (a slave's GSD) are relative to them and installed with
    them, so the file runs as it is: `Daemon(find_example("plc-line.json"))`. Raises
    Candp2Error naming every place it looked."""
    tried: list[str] = []
    folders: list[Path] = []
    if os.environ.get(EXAMPLES_ENV):
        folders.append(Path(os.environ[EXAMPLES_ENV]))
    root = _checkout()
    if root is not None:
        folders.append(root / "config")
    for folder in folders:
        candidate = folder / name
        if candidate.is_file():
            return candidate
        tried.append(str(candidate))
    try:
        binary = Path(find_binary(candp2d)).resolve()
    except Candp2Error as e:
        tried.append("beside candp2d (%s)" % e)
    else:
        candidates = [binary.parent.parent / EXAMPLES_DIR / name]
        source = build_source(binary)
        if source is not None:
            candidates.append(source / "config" / name)
        for candidate in candidates:
            if candidate.is_file():
                return candidate
            tried.append(str(candidate))
    raise Candp2Error("no example %s (tried %s; $%s names a folder of them)"
                      % (name, ", ".join(tried), EXAMPLES_ENV))


def example(name: str, candp2d: str | os.PathLike[str] | None = None) -> Path:
    """The path of a shipped example configuration or scenario ("demo.json",
    "scenarios/demo.json"), in the source checkout and when installed alike, from any working
    folder: `candp2.Daemon(candp2.example("demo.json"))`. The same as find_example()."""
    return find_example(name, candp2d)
