"""Constants shared by the run-guest modules: exit codes, console markers, errors, logging."""

from __future__ import annotations

import sys

PROG = "run-guest"

# Bump when the image layout or the init script changes in a way the content key would not catch.
IMAGE_FORMAT = "candp2-qemu-image-1"

# Exit codes of the harness itself (the guest script's own code is passed through otherwise).
EXIT_TIMEOUT = 124  # like timeout(1): the overall time limit was hit, QEMU was killed
EXIT_HARNESS = 125  # usage error, missing host package, guest did not boot or did not report

# Console marker lines written by the guest init (guest-init.sh) and parsed in qemu.py.
MARK_BEGIN = "CANDP2-GUEST-BEGIN"
MARK_END = "CANDP2-GUEST-END"
MARK_EXIT = "CANDP2-GUEST-EXIT="
MARK_SETUP_FAILED = "CANDP2-GUEST-SETUP-FAILED:"
MARK_OUT_BEGIN = "CANDP2-GUEST-OUT-BEGIN"
MARK_OUT_END = "CANDP2-GUEST-OUT-END"


class HarnessError(Exception):
    """A failure of the harness or of the guest before it reported the script's exit code."""


def log(msg: str) -> None:
    print(f"{PROG}: {msg}", file=sys.stderr, flush=True)
