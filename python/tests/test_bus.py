"""candp2.Bus: the socketcand framing, expect() and its failure message, record()."""

import json
import re
from pathlib import Path
from typing import Callable

import pytest
from can.message import Message

from candp2 import Daemon, FrameNotSeen, UnexpectedFrame, candump_line, frame_text
from candp2.bus import ElementSplitter, format_send, parse_element

from plants import MANUAL_514, settled

Factory = Callable[..., Daemon]


def test_framing_is_socketcand_raw_mode() -> None:
    msg = Message(arbitration_id=0x309, data=bytes.fromhex("0B0A0F"), is_extended_id=False)
    assert format_send(msg) == "< send 309 3 b a f >"
    ext = Message(arbitration_id=0x1234567, data=b"", is_extended_id=True)
    assert format_send(ext) == "< send 01234567 0 >"
    got = parse_element("< frame 01234567 1700000000.250000 AABB >")
    assert got is not None and got.is_extended_id and got.arbitration_id == 0x1234567
    assert bytes(got.data) == b"\xAA\xBB" and got.timestamp == 1700000000.25
    got = parse_element("< frame 309 1.000000  >")
    assert got is not None and not got.is_extended_id and got.dlc == 0
    assert parse_element("< ok >") is None
    error = parse_element("< error 20000004 1.000000 >")
    assert error is not None and error.is_error_frame
    assert frame_text(ext) == "01234567#"
    assert candump_line(got, "can0") == "(1.000000) can0 309#"


def test_splitter_keeps_partial_elements() -> None:
    s = ElementSplitter()
    assert s.feed("< hi >< fra") == ["< hi >"]
    assert s.feed("me 123 1.0 01 >junk< ok") == ["< frame 123 1.0 01 >"]
    assert s.feed(" >") == ["< ok >"]


def test_round_trip_through_the_gateway(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    with daemon.bus("can0") as can0:
        gw.wait_until(lambda g: g.state == "Data_Exch")
        gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
        got = can0.expect(0x309, bytes.fromhex("0B0A0F0E0D0C"))  # form B8 swaps
        assert not got.is_extended_id and got.channel == "can0"
        can0.send(Message(arbitration_id=0x289, data=bytes.fromhex("0B0A0F0E0D0C"),
                          is_extended_id=False))
        gw.wait_until(lambda g: g.inputs[172:178] == bytes.fromhex("0A0B0C0D0E0F"))
        assert frame_text(can0.history[-1]) == "309#0B0A0F0E0D0C"  # not its own frames


def test_failing_expect_lists_what_it_saw(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    settled(gw)
    can0 = daemon.bus("can0")
    gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
    with pytest.raises(FrameNotSeen) as info:
        can0.expect(0x309, bytes.fromhex("0102030405"), timeout=2.0)
    assert str(info.value) == ("frame 309#0102030405 not seen on can0 within 2.0 s; saw 1 "
                               "frame: 309#0B0A0F0E0D0C\n"
                               "identifier 0x309 is used by: gateway 5 (gw5) slot 1: output "
                               "Q172..177 (6 bytes) to CAN 0x309, form B8, comment 03,09,B8")
    assert len(info.value.seen) == 1
    with pytest.raises(FrameNotSeen, match=r"frame 181#\* not seen on can0 within 0.2 s; "
                                           r"saw no frames"):
        can0.expect(0x181, timeout=0.2)


def test_expect_no_frame(candp2d: Factory) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    settled(gw)
    can0 = daemon.bus("can0")
    can0.expect_no_frame(duration=0.2)
    gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
    with pytest.raises(UnexpectedFrame, match=r"any frame on can0 within 1.0 s: saw 1 frame: "
                                              r"309#0B0A0F0E0D0C"):
        can0.expect_no_frame(duration=1.0)


def test_record_writes_candump_log(candp2d: Factory, tmp_path: Path) -> None:
    daemon = candp2d(MANUAL_514)
    gw = daemon.gateway(5)
    settled(gw)
    can0 = daemon.bus("can0")
    log = tmp_path / "can0.log"
    with can0.record(log) as recorder:
        gw.outputs[172:178] = bytes.fromhex("0A0B0C0D0E0F")
        can0.expect(0x309)
        can0.send(Message(arbitration_id=0x289, data=b"\x01", is_extended_id=False))
        gw.wait_until(lambda g: recorder.frames == 2)
    lines = log.read_text().splitlines()
    assert [line.split(" ", 1)[1] for line in lines] == ["can0 309#0B0A0F0E0D0C",
                                                         "can0 289#01"]
    assert all(re.match(r"^\(\d+\.\d{6}\) ", line) for line in lines)


def test_a_bus_without_export(candp2_binary: str) -> None:
    config = json.loads(json.dumps(MANUAL_514))
    config["buses"]["can1"] = {"type": "socketcand", "host": "127.0.0.1", "port": 1,
                               "channel": "x"}
    with Daemon(config, candp2_binary) as daemon:
        with pytest.raises(KeyError, match="exported: can0"):
            daemon.bus("can1")
