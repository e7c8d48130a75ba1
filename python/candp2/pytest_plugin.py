"""The candp2 pytest plugin (entry point `pytest11`, loaded wherever the package is installed).

Fixtures:
  candp2_binary  the candp2d to test: option --candp2d PATH, else candp2d on PATH, else the
                 build tree of the source checkout
  candp2d        a factory: candp2d(config, **kwargs) starts a candp2.Daemon (on free loopback
                 ports, so tests run in parallel under pytest-xdist) and stops it at teardown

When a test fails, its report carries a section per running daemon: every gateway's state and
decoded diagnosis, every generic slave's state, decoded diagnosis, faults and field side, the
line (baud rate, bus cycle, live list, each station's counters and active fault), the last CAN
frames of each bus and the daemon's log tail.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Generator, Iterator, Mapping

import pytest

from .binary import find_binary, set_session_binary
from .daemon import Daemon, running_daemons
from .errors import Candp2Error, DaemonError


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("candp2", "candp2 (the CAN-DP/2 emulator)")
    group.addoption("--candp2d", action="store", default=None, metavar="PATH",
                    help="the candp2d to test against (default: candp2d on PATH, else the "
                         "build tree of the candp2 source checkout)")


def pytest_configure(config: pytest.Config) -> None:
    # --candp2d is the session's candp2d everywhere: the fixtures, Daemon(config) without a
    # binary, candp2.example() (which looks beside it).
    explicit: str | None = config.getoption("candp2d", None)
    if explicit is not None:
        try:
            set_session_binary(explicit)
        except Candp2Error:
            pass  # the candp2_binary fixture says why, in the test that needs it


@pytest.fixture(scope="session")
def candp2_binary(request: pytest.FixtureRequest) -> str:
    """The candp2d the tests run: --candp2d PATH, else PATH, else the build tree."""
    explicit: str | None = request.config.getoption("candp2d")
    return find_binary(explicit)


class DaemonFactory:
    """`candp2d(config, **kwargs)`: a running candp2.Daemon of `config` (a dict or a path),
    stopped when the test ends. Keyword arguments go to Daemon (timeout, args)."""

    def __init__(self, binary: str) -> None:
        self.binary = binary
        self.daemons: list[Daemon] = []

    def __call__(self, config: Mapping[str, Any] | str | os.PathLike[str],
                 **kwargs: Any) -> Daemon:
        kwargs.setdefault("binary", self.binary)
        daemon = Daemon(config, **kwargs)
        self.daemons.append(daemon)
        return daemon

    def stop_all(self) -> None:
        """Stops every daemon; raises DaemonError for the first one that had died or did not
        stop cleanly (after stopping the rest)."""
        errors: list[DaemonError] = []
        for d in self.daemons:
            if d.stopped:
                continue  # stopped by the test itself
            try:
                d.stop()
            except DaemonError as e:
                errors.append(e)
        self.daemons.clear()
        if errors:
            raise errors[0]


@pytest.fixture
def candp2d(candp2_binary: str) -> Iterator[Callable[..., Daemon]]:
    """Starts candp2d for this test: `daemon = candp2d(config)`; stopped at teardown (a daemon
    that died during the test fails the teardown with its log)."""
    factory = DaemonFactory(candp2_binary)
    try:
        yield factory
    finally:
        factory.stop_all()


@pytest.hookimpl(hookwrapper=True)  # type: ignore[misc]
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]
                              ) -> Generator[None, Any, None]:
    outcome = yield
    report: pytest.TestReport = outcome.get_result()
    if report.when != "call" or not report.failed:
        return
    for i, daemon in enumerate(running_daemons()):
        try:
            text = daemon.report()
        except Exception as e:  # a report must never hide the test's own failure
            text = "no report: %s" % e
        report.sections.append(("candp2d %d (modbus %s:%d)" % ((i,) + daemon.modbus_address),
                                text))
