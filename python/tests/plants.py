"""Plants shared by the package's own tests (python/tests)."""

from pathlib import Path
from typing import Any

from candp2 import Gateway

# manual §5.1.4: input I 172..177 from CAN 0x289, output Q 172..177 to 0x309, form B8 (the
# gateway swaps bytes 1-2 and 3-6: a b c d e f -> b a f e d c).
MANUAL_514: dict[str, Any] = {
    "master": {"address": 1, "cycle_ms": 2, "retry_ms": 100},
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{
        "name": "gw5", "address": 5, "bus": "can0",
        "parameters": {"can_bitrate": "125k", "can_diagnosis": True, "watchdog_ms": 500},
        "slots": [
            {"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
            {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"},
        ],
    }],
}


def settled(gw: Gateway) -> None:
    """Waits until the gateway is in Data_Exch and has sent its output slot once (the first
    Data_Exchange's bytes, docs/decisions.md "Initial transmission"), so that a bus opened
    afterwards sees only what the test causes."""
    gw.wait_until(lambda g: g.state == "Data_Exch" and g.counters.tx_frames >= 1)


#: The source checkout (these tests run from it).
ROOT = Path(__file__).resolve().parent.parent.parent
#: The example GSD of our own (docs/slaves.md): a modular I/O station, Ident 0x0C2D, Sync and
#: Freeze, Fail_Safe, Max_Diag_Data_Len 16.
EXAMPLE_GSD = str(ROOT / "gsd" / "examples" / "CDP20C2D.GSD")

# A gateway and two generic slaves on one master, as config/plc-line.json (without drives):
# io1 (8): 8 DI at I 100, 8 DO at Q 100, 2 AI at I 101..104, field side on unit 108; io2 (9):
# 16 DI at I 110..111, 16 DO at Q 110..111, field side on unit 109.
PLC_LINE: dict[str, Any] = {
    "master": {"address": 1, "cycle_ms": 2, "retry_ms": 100},
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{
        "name": "gw3", "address": 3, "bus": "can0",
        "parameters": {"watchdog_ms": 200},
        "slots": [{"io": "output", "address": 0, "length": 2, "comment": "02,01,00"}],
    }],
    "slaves": [
        {"name": "io1", "address": 8, "gsd": EXAMPLE_GSD, "modules": ["8 DI", "8 DO", "2 AI"],
         "field_unit": 108, "watchdog_ms": 200, "input_address": 100, "output_address": 100},
        {"name": "io2", "address": 9, "gsd": EXAMPLE_GSD, "modules": ["16 DI", "16 DO"],
         "field_unit": 109, "watchdog_ms": 200, "input_address": 110, "output_address": 110},
    ],
}
