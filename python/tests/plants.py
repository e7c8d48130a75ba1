"""Plants shared by the package's own tests (python/tests)."""

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
