"""`candp2 replay`: a deterministic scenario in virtual time (docs/replay-format.md), run from
Python."""

from __future__ import annotations

import json
import os
import re
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from .binary import find_tool
from .errors import Candp2Error, ConfigError

# "    30.000 ms  ok    #4 expect_diag ..." (docs/replay-format.md "Report").
_STEP = re.compile(r"^\s*(?P<time>\d+\.\d+) ms  (?P<status>ok|FAIL|  )\s*#(?P<n>\d+) (?P<text>.*)$")


@dataclass(frozen=True)
class ReplayStep:
    """One step of the report: its number, the virtual time it started (ms), `status` "ok" or
    "FAIL" for expectations ("" for actions), its text, and for a failure what was seen instead
    (`detail`)."""

    number: int
    time_ms: float
    status: str
    text: str
    detail: str = ""

    @property
    def failed(self) -> bool:
        return self.status == "FAIL"


@dataclass(frozen=True)
class ReplayResult:
    """What `replay()` returns: every step, the failed ones, the JUnit file, the report text
    and candp2's exit status (0 all expectations held, 1 some failed)."""

    steps: list[ReplayStep]
    failures: list[ReplayStep]
    junit: Path
    report: str
    returncode: int

    @property
    def passed(self) -> bool:
        return self.returncode == 0 and not self.failures


def parse_report(text: str) -> list[ReplayStep]:
    """The steps of a `candp2 replay` report; a failure's following "=>" lines become its
    detail."""
    steps: list[ReplayStep] = []
    for line in text.splitlines():
        m = _STEP.match(line)
        if m:
            steps.append(ReplayStep(int(m.group("n")), float(m.group("time")),
                                    m.group("status").strip(), m.group("text").strip()))
        elif steps and line.strip().startswith("=>"):
            last = steps[-1]
            detail = (last.detail + "\n" if last.detail else "") + line.strip()[2:].strip()
            steps[-1] = ReplayStep(last.number, last.time_ms, last.status, last.text, detail)
    return steps


def replay(scenario: Mapping[str, Any] | str | os.PathLike[str], *,
           junit: str | os.PathLike[str] | None = None,
           can_log: str | os.PathLike[str] | None = None,
           tool: str | os.PathLike[str] | None = None,
           candp2d: str | None = None, timeout: float = 120.0) -> ReplayResult:
    """Runs `candp2 replay` on `scenario` (a path, or the scenario as a dict) and returns its
    steps, failures and JUnit file (`junit`, default a temporary file that is kept).

    `tool` is the candp2 executable (default: beside `candp2d`, else found like
    `find_binary()`). A scenario candp2 cannot use raises ConfigError with its JSON path."""
    exe = find_tool(candp2d, tool)
    work = Path(tempfile.mkdtemp(prefix="candp2-replay-"))
    if isinstance(scenario, (str, os.PathLike)):
        path = Path(scenario)
    else:
        path = work / (str(scenario.get("name", "scenario")) + ".json")
        path.write_text(json.dumps(scenario, indent=2))
    junit_path = Path(junit) if junit is not None else work / "junit.xml"
    argv = [exe, "replay", str(path), "--junit", str(junit_path)]
    if can_log is not None:
        argv += ["--can-log", os.fspath(can_log)]
    try:
        r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise Candp2Error("%s: %s" % (" ".join(argv), e)) from e
    if r.returncode == 2:
        raise ConfigError.from_output(r.stderr + r.stdout, 2) or Candp2Error(
            "%s: exit status 2\n%s" % (" ".join(argv), r.stderr))
    if r.returncode not in (0, 1):
        raise Candp2Error("%s: exit status %d\n%s" % (" ".join(argv), r.returncode, r.stderr))
    steps = parse_report(r.stdout)
    return ReplayResult(steps, [s for s in steps if s.failed], junit_path, r.stdout,
                        r.returncode)
