"""candp2.replay(): steps, failures, the JUnit file; a bad scenario's JSON path."""

from pathlib import Path
from typing import Any

import pytest

from candp2 import ConfigError, replay

from plants import MANUAL_514


def scenario(steps: list[dict[str, Any]]) -> dict[str, Any]:
    return {"format": "candp2-replay", "version": 1, "name": "py",
            "gateway": MANUAL_514["gateways"][0], "steps": steps}


def test_passing_and_failing_steps(candp2_binary: str, tmp_path: Path) -> None:
    result = replay(scenario([
        {"expect_dp_state": "data_exch", "within_ms": 100},
        {"write": {"address": 172, "bytes": "0A 0B 0C 0D 0E 0F"}},
        {"expect_frame": "309#0B0A0F0E0D0C", "within_ms": 30},
        {"expect_frame": "309#010203040506", "within_ms": 30},
    ]), candp2d=candp2_binary, junit=tmp_path / "junit.xml")
    assert not result.passed and result.returncode == 1
    assert [s.status for s in result.steps] == ["ok", "", "ok", "FAIL"]
    (failure,) = result.failures
    assert failure.number == 4 and failure.text.startswith("expect_frame 309#010203040506")
    assert failure.detail != ""
    assert result.junit == tmp_path / "junit.xml"
    assert 'failures="1"' in result.junit.read_text()


def test_a_scenario_candp2_cannot_use(candp2_binary: str) -> None:
    with pytest.raises(ConfigError) as info:
        replay(scenario([{"whitin_ms": 3}]), candp2d=candp2_binary)
    assert info.value.path == "$.steps[0]"
