"""The built-in master's PROFIBUS line in time (docs/profibus.md "The line in time"): its baud
rate and the bus cycle candp2d measures, as `/api/v1/status` shows them under "line"."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping


@dataclass(frozen=True)
class BusCycle:
    """The measured bus cycle (one token rotation) in microseconds: the last, the shortest, the
    mean and the longest, over `cycles` rotations."""

    last: int
    min: int
    mean: int
    max: int
    cycles: int


@dataclass(frozen=True)
class Line:
    """`baud` (bit/s), the measured `bus_cycle_us`, the requests the master repeated
    (`retries`) and the FDL-Status requests into its GAP (`gap_polls`)."""

    baud: int
    bus_cycle_us: BusCycle
    retries: int
    gap_polls: int

    @classmethod
    def from_status(cls, line: Mapping[str, Any]) -> Line:
        c = line["bus_cycle_us"]
        return cls(int(line["baud"]),
                   BusCycle(int(c["last"]), int(c["min"]), int(c["mean"]), int(c["max"]),
                            int(c["cycles"])),
                   int(line["retries"]), int(line["gap_polls"]))
