"""What a newcomer tripped over, each made impossible (docs/python.md "No traps"): an LED is no
truth value, bytes print in hex, a failed expect() says who uses the identifier and what the
drives do, report times count from the test's start, the shipped examples are found from any
folder, and a missing configuration file is a clear error."""

import os
import re
import time
from pathlib import Path
from typing import Callable

import pytest

import candp2
from candp2 import ConfigError, Daemon, FrameNotSeen, Led, WaitTimeout
from candp2.station import HexBytes

from plants import MANUAL_514

Factory = Callable[..., Daemon]


def test_an_led_is_not_a_truth_value() -> None:
    off = Led("off", 0)
    with pytest.raises(TypeError, match=r'leds\.P == "on"'):
        bool(off)
    with pytest.raises(TypeError):
        assert off  # what `assert gw.leds.P` did: passed for "off" too
    assert off == "off" and off != "on" and Led("3 flashes", 3) == Led("3 flashes", 3)
    assert "flashes" in Led("3 flashes", 3) and str(off) == "off" and repr(off) == "Led('off')"


def test_leds_of_a_running_gateway_compare_by_text(candp2d: Factory) -> None:
    gw = candp2d(MANUAL_514).gateway(5)
    gw.wait_until(lambda g: g.state == "Data_Exch")
    leds = gw.leds
    assert isinstance(leds.D, Led) and leds.D == "on" and leds.E == "off"
    with pytest.raises(TypeError):
        gw.wait_until(lambda g: g.leds.D, timeout=0.1)


def test_bytes_print_in_hex() -> None:
    data = HexBytes(b"\xa8\x00\x26")
    assert data == b"\xa8\x00\x26" and str(data) == "A8 00 26"
    assert repr(data) == "bytes.fromhex('A8 00 26')" and eval(repr(data)) == data


def test_wait_timeout_shows_bytes_in_hex(candp2d: Factory) -> None:
    gw = candp2d(MANUAL_514).gateway(5)
    gw.outputs[0:2] = b"\xa8\x01"
    with pytest.raises(WaitTimeout) as failed:
        gw.wait_until(lambda g: g.outputs[0:2] == b"\x00\x00", timeout=0.2)
    seen = str(failed.value).split("last saw ", 1)[1].split(" (predicate", 1)[0]
    assert seen == "outputs[0:2]=[A8 01]", seen


def test_failed_expect_names_the_users_of_the_identifier(candp2d: Factory) -> None:
    daemon = candp2d(candp2.example("demo.json"))
    gw, can0 = daemon.gateway(3), daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    with pytest.raises(FrameNotSeen) as unused:
        can0.expect(0x7F0, timeout=0.2)
    assert "no slot and no drive on can0 uses identifier 0x7F0" in str(unused.value)
    with pytest.raises(FrameNotSeen) as used:
        can0.expect(0x201, bytes.fromhex("99"), timeout=0.2)
    text = str(used.value)
    assert re.search(r"identifier 0x201 is used by: gateway 3 \(\w+\) slot 0: output", text)
    assert "drive axis1 receives its commands on it" in text
    assert re.search(r"drive axis1: (enabled|disabled), \w+ mode, speed -?\d+", text)
    assert re.search(r"drive axis2: (enabled|disabled)", text)


def test_report_times_count_from_the_test_start(candp2d: Factory) -> None:
    start = time.monotonic()
    daemon = candp2d(candp2.example("demo.json"))
    gw, can0 = daemon.gateway(3), daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.outputs[0:5] = bytes.fromhex("51 00 00 00 00")
    can0.expect(0x201, bytes.fromhex("51 00 00 00 00"))
    report = daemon.report()
    elapsed = time.monotonic() - start
    times = [float(t) for t in re.findall(r"^\s+([+-]\d+\.\d+) s\s+201#5100000000$", report,
                                          re.M)]
    assert times, report
    assert all(-0.05 <= t <= elapsed + 0.05 for t in times), (times, elapsed, report)


def test_examples_are_found_from_any_folder(tmp_path: Path) -> None:
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        demo = candp2.example("demo.json")
        assert demo.is_absolute() and demo.is_file() and demo.name == "demo.json"
        assert candp2.example("scenarios/demo.json").is_file()
        with pytest.raises(ConfigError, match=r"demo\.json: no such file") as missing:
            Daemon("config/demo.json")
        assert "candp2.example" in str(missing.value)
    finally:
        os.chdir(here)


def test_a_daemon_that_never_started_still_prints() -> None:
    with pytest.raises(ConfigError) as missing:
        Daemon("/nonexistent/candp2.json")
    assert "/nonexistent/candp2.json" in str(missing.value)
    broken = Daemon.__new__(Daemon)  # what a traceback shows of a half-built Daemon
    assert repr(broken).endswith("not started>")
