"""Shared by the e2e tests: wait for one CAN frame on a python-can bus."""
import time


def expect_frame(bus, arbitration_id, data, timeout):
    """Waits until the frame is seen (other frames may pass first); AssertionError naming what was
    seen instead when `timeout` seconds pass."""
    seen = []
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        msg = bus.recv(timeout=max(0.0, end - time.monotonic()))
        if msg is None:
            break
        seen.append("%03X#%s" % (msg.arbitration_id, msg.data.hex().upper()))
        if msg.arbitration_id == arbitration_id and bytes(msg.data) == bytes(data):
            return
    raise AssertionError("frame %03X#%s not seen; saw %s" % (arbitration_id,
                                                             bytes(data).hex().upper(), seen))
