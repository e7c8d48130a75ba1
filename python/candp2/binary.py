"""Which candp2d (and candp2) to run.

The order is the pytest plugin's (`candp2_binary`): a path given explicitly, else `candp2d` on
PATH (the Debian package puts it in /usr/bin), else the build tree of the source checkout this
package was imported from (`build/bin/candp2d`, then `build-release/bin/candp2d`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .errors import Candp2Error

#: Build directories of a source checkout, searched in this order (README.md, tools/setup.sh).
BUILD_DIRS = ("build", "build-release")


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
                      "Daemon(binary=...))" % (name, ", ".join(tried)))


def find_binary(explicit: str | os.PathLike[str] | None = None) -> str:
    """The candp2d to run: `explicit` if given, else PATH, else the source checkout's build tree.

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
