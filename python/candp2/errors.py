"""The exceptions of the candp2 package.

Every error a test can meet says what happened in words a test engineer reads: a daemon that
would not start carries the tail of its log, a refused configuration the JSON path of the error,
a refused Modbus request the exception's name, a wait or an expectation that failed what it saw
instead.
"""

from __future__ import annotations

import re

#: How many lines of the daemon's log an exception carries.
LOG_TAIL_LINES = 40


def log_tail(text: str, lines: int = LOG_TAIL_LINES) -> str:
    """The last `lines` lines of `text` (all of it when shorter)."""
    return "\n".join(text.rstrip("\n").splitlines()[-lines:])


class Candp2Error(Exception):
    """Base class of every error this package raises (except the AssertionErrors of failed
    waits and expectations, which a test framework reports as test failures)."""


class DaemonError(Candp2Error):
    """candp2d could not start, exited, or did something else a test cannot carry on from.

    `returncode` is the exit status (None while it runs), `log` the daemon's output so far; the
    message ends with the log's tail.
    """

    def __init__(self, message: str, log: str = "", returncode: int | None = None) -> None:
        self.returncode = returncode
        self.log = log
        text = message
        if log.strip():
            text += "\n--- candp2d log (last lines) ---\n" + log_tail(log)
        super().__init__(text)


# "candp2d: error: FILE: $.gateways[0].bus: unknown bus ..."
# (docs/configuration.md "General rules").
# `candp2 replay` says "candp2 replay: FILE: PATH: ..." (docs/replay-format.md).
_CONFIG_ERROR = re.compile(
    r"^(?:candp2d: error|candp2 replay): (?P<file>.+?): (?:(?P<path>\$[^ ]*?): )?"
    r"(?P<message>.*)$", re.M)


class ConfigError(DaemonError):
    """candp2d (or `candp2 replay`) refused the configuration (exit status 2).

    `path` is the JSON path of the error ("$.gateways[0].slots[1].length"; None for file-level
    errors such as invalid JSON), `file` the file it named, `message` what was expected.
    """

    def __init__(self, file: str, path: str | None, message: str, log: str = "",
                 returncode: int | None = 2) -> None:
        self.file = file
        self.path = path
        self.message = message
        where = "%s: %s" % (file, path) if path else file
        super().__init__("configuration refused: %s: %s" % (where, message), log, returncode)

    @classmethod
    def from_output(cls, output: str, returncode: int | None = 2) -> ConfigError | None:
        """The first "candp2d: error: FILE: PATH: message" (or "candp2 replay: FILE: PATH:
        message") line of `output`, or None."""
        m = _CONFIG_ERROR.search(output)
        if not m:
            return None
        return cls(m.group("file"), m.group("path"), m.group("message"), output, returncode)


class ModbusError(Candp2Error):
    """A Modbus request was answered with an exception (or not at all).

    `code` is the Modbus exception code (None: no answer, the connection failed), `name` its
    name as the daemon's register map gives it ("illegal data address").
    """

    def __init__(self, request: str, code: int | None, name: str) -> None:
        self.request = request
        self.code = code
        self.name = name
        if code is None:
            super().__init__("%s: %s" % (request, name))
        else:
            super().__init__("%s: exception 0x%02X (%s)" % (request, code, name))


class NoLine(Candp2Error, AttributeError):
    """`daemon.line` of a daemon whose master runs an ideal line (no `master.baud`): there are
    no line statistics and no line faults. An AttributeError too, so `getattr(daemon, "line",
    None)` is None there (`daemon.has_line` says the same)."""


class WaitTimeout(AssertionError):
    """`Gateway.wait_until()` (and the other waits) gave up; the message says what was last seen."""


class FrameNotSeen(AssertionError):
    """`Bus.expect()` did not see the frame; the message lists the frames it saw instead.
    `seen` holds them as can.Message objects."""

    def __init__(self, message: str, seen: list[object]) -> None:
        self.seen = seen
        super().__init__(message)


class UnexpectedFrame(AssertionError):
    """`Bus.expect_no_frame()` saw a frame it should not have; the message lists them."""

    def __init__(self, message: str, seen: list[object]) -> None:
        self.seen = seen
        super().__init__(message)
