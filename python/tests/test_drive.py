"""candp2.Drive: the HTTP face's view and the fault registers."""

from typing import Any, Callable

from candp2 import Daemon

Factory = Callable[..., Daemon]

PLANT: dict[str, Any] = {
    "buses": {"can0": {"type": "virtual"}},
    "gateways": [{"name": "gw3", "address": 3, "bus": "can0", "slots": [
        {"io": "output", "address": 0, "length": 5, "comment": "02,01,00"},
        {"io": "input", "address": 0, "length": 6, "comment": "01,81,00"}]}],
    "drives": [{"name": "axis1", "bus": "can0"}],
}
READ_MODE = bytes.fromhex("3D 51 00 00 00")
READ_STATUS = bytes.fromhex("3D 40 00 00 00")


def test_mute_error_bits_restart(candp2d: Factory) -> None:
    daemon = candp2d(PLANT)
    gw, can0, axis1 = daemon.gateway(3), daemon.bus("can0"), daemon.drive("axis1")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    assert axis1.speed == 0 and axis1.state.mode == "speed"
    gw.outputs[0:5] = READ_MODE
    can0.expect(0x201, READ_MODE)
    can0.expect(0x181)
    axis1.mute()
    gw.outputs[0:5] = READ_STATUS
    can0.expect(0x201, READ_STATUS)
    can0.expect_no_frame(0x181, duration=0.3)   # a muted drive does not answer
    axis1.mute(False)
    gw.outputs[0:5] = READ_MODE
    can0.expect(0x201, READ_MODE)
    can0.expect(0x181)
    axis1.error_bits(0x0004)
    axis1.warning_bits(0x0001)
    axis1.restart()                             # power-on state: bits 0 again
    gw.outputs[0:5] = bytes.fromhex("3D 8F 00 00 00")
    reply = can0.expect(0x181)
    assert bytes(reply.data)[0] == 0x8F and bytes(reply.data)[1:5] == bytes(4)
