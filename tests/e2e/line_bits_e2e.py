"""The line in time keeps its bits in candp2d (docs/profibus.md "The line in time", "Bus cycle and
token rotation"), on its pcapng capture: with the cycles back to back, the line steps of real
time move no telegram.

Two lines, `cycle_ms` 1, each shorter than one rotation (so the rotations run back to back):

  - 4 gateways, 8 bytes each way, at 187.5 kbit/s (a rotation about 8.2 ms);
  - 3 gateways, 144 bytes out and 152 in, min_TSDR 200, at 12 Mbit/s (a rotation about 1.04 ms).

For each, about a second of line:

  - every idle from the master's token to the next rotation's first request is TID2 (from the
    bus parameters `candp2 validate` prints): to the bit at 187.5 kbit/s (a bit is 5.3 µs, the
    stamps are whole microseconds); within the stamps' microsecond at 12 Mbit/s (12 bits);
  - the token rotation of `candp2 sniff --stats` (mean, token to token), the bus cycle of GET
    /api/v1/status over the same run (mean of the rotations after the start-up) and the
    prediction of `candp2 validate` agree within 1 %.

The stamps are simulated time (docs/daemon.md "Host stalls"), so a loaded host changes nothing
here. Bounded: every wait has a deadline.
"""

import json
import os
import struct
import subprocess
import time

import pytest

CANDP2 = os.environ.get("CANDP2_TOOL", "")
TOKEN_BITS = 3 * 11  # SD4: 3 characters of 11 bits
EPB, IDB = 6, 1  # pcapng Enhanced Packet Block, Interface Description Block
LINKTYPE_WIRESHARK_UPPER_PDU = 252  # candp2d's PROFIBUS interface (docs/capture.md)


def gateway(address, outputs, inputs):
    """A gateway at `address` with `outputs` and `inputs` 8-byte slots."""
    base = (address - 3) * 160
    slots = [{"io": "output", "address": base + 8 * k, "length": 8,
              "comment": "01,%02X,00" % ((address - 3) * 20 + k)} for k in range(outputs)]
    slots += [{"io": "input", "address": base + 8 * k, "length": 8,
               "comment": "03,%02X,00" % ((address - 3) * 20 + k)} for k in range(inputs)]
    return {"name": "gw%d" % address, "address": address, "bus": "can0", "slots": slots}


def line(baud, gateways, capture, bus_parameters=None):
    master = {"address": 1, "cycle_ms": 1, "baud": baud}
    if bus_parameters:
        master["bus_parameters"] = bus_parameters
    return {"modbus": {"listen": "127.0.0.1:0"}, "http": {"listen": "127.0.0.1:0"},
            "master": master, "buses": {"can0": {"type": "virtual"}}, "gateways": gateways,
            "capture": {"pcapng": str(capture)}, "log": {"level": "info"}}


LINES = {
    "187k5-4x8": (187500, [gateway(a, 1, 1) for a in (3, 4, 5, 6)], None),
    "12M-3x296": (12000000, [gateway(a, 18, 19) for a in (3, 4, 5)], {"min_tsdr_bits": 200}),
}


def telegrams(path):
    """(time stamp in ns, telegram bytes) of the PROFIBUS interface of a pcapng capture."""
    data = open(path, "rb").read()
    profibus, out, i = None, [], 0
    interfaces = 0
    while i + 12 <= len(data):
        kind, length = struct.unpack_from("<II", data, i)
        if length < 12 or i + length > len(data):
            break  # a cut block at the end
        if kind == IDB:
            if struct.unpack_from("<H", data, i + 8)[0] == LINKTYPE_WIRESHARK_UPPER_PDU:
                profibus = interfaces if profibus is None else profibus
            interfaces += 1
        elif kind == EPB:
            iface, high, low, caplen = struct.unpack_from("<IIII", data, i + 8)
            if iface == profibus:
                packet = data[i + 28:i + 28 + caplen]
                # The exported PDU's tags end with tag 0, length 0 (docs/capture.md).
                j = 0
                while j + 4 <= len(packet):
                    tag, tlen = struct.unpack_from(">HH", packet, j)
                    j += 4 + tlen
                    if tag == 0:
                        break
                out.append((((high << 32) | low), packet[j:]))
        i += length
    return out


def tid2_bits(p):
    """docs/profibus.md "The model": TID2 = max(TSYN + TSM, max_TSDR), TSM = 2 + 2 Tset + Tqui."""
    return max(33 + 2 + 2 * p["tset_bits"] + p["tqui_bits"], p["max_tsdr_bits"])


def steady_mean(first, second):
    """The mean bus cycle (µs) of the rotations measured between two status documents."""
    a, b = first["line"]["bus_cycle_us"], second["line"]["bus_cycle_us"]
    n = b["cycles"] - a["cycles"]
    assert n > 0, (a, b)
    return (b["mean"] * b["cycles"] - a["mean"] * a["cycles"]) / n


@pytest.mark.skipif(not CANDP2, reason="CANDP2_TOOL: the candp2 tool")
@pytest.mark.parametrize("name", sorted(LINES))
def test_back_to_back_rotations_keep_tid2(candp2d, tmp_path, name):
    baud, gateways, bus_parameters = LINES[name]
    capture = tmp_path / "line.pcapng"
    config = line(baud, gateways, capture, bus_parameters)
    config_file = tmp_path / "line.json"
    config_file.write_text(json.dumps(config))
    validate = subprocess.run([CANDP2, "validate", "--json", str(config_file)],
                              capture_output=True, text=True, timeout=30)
    predicted = json.loads(validate.stdout)["line"]
    cycle_ms = config["master"]["cycle_ms"]
    assert predicted["bus_cycle_us"] > cycle_ms * 1000, "the rotations must run back to back"
    tid2 = tid2_bits(predicted["bus_parameters"])

    daemon = candp2d(config)
    everyone = len(gateways)
    deadline = time.monotonic() + 20
    while True:  # every station in Data_Exch: the start-up is over
        status = daemon.http_status()
        if len(status["line"]["live_list"]["ok"]) == everyone and all(
                g["master_state"] == "Data_Exch" for g in status["gateways"]):
            break
        assert time.monotonic() < deadline, json.dumps(status)[:2000]
        time.sleep(0.05)
    first = status
    # About a second of line: 120 rotations at 187.5 kbit/s, 1000 at 12 Mbit/s.
    rotations = max(100, 1000000 // predicted["bus_cycle_us"])
    while status["line"]["bus_cycle_us"]["cycles"] < first["line"]["bus_cycle_us"]["cycles"] + \
            rotations:
        assert time.monotonic() < deadline + 20, json.dumps(status["line"])[:2000]
        time.sleep(0.1)
        status = daemon.http_status()
    daemon.stop()
    bus_cycle = steady_mean(first, status)

    # Token to the next rotation's first request: TID2.
    line_telegrams = telegrams(capture)
    bit_ns = 1e9 / baud
    idles = []
    for (t0, token), (t1, _) in zip(line_telegrams, line_telegrams[1:]):
        if token[:1] == b"\xdc":
            idles.append((t1 - t0) / bit_ns - TOKEN_BITS)
    assert len(idles) >= rotations, len(idles)
    # A stamp is the first whole microsecond at or after its bit: two stamps tell a difference
    # of bits within one microsecond.
    slack = max(1000 / bit_ns, 0.5)
    wrong = [x for x in idles if abs(x - tid2) > slack]
    assert not wrong, "%d of %d idles after the token are not TID2 (%d bits): %s" % (
        len(wrong), len(idles), tid2, sorted(set(round(x) for x in wrong))[:20])

    sniffed = subprocess.run([CANDP2, "sniff", "--stats", "--json", str(capture)],
                             capture_output=True, text=True, timeout=60)
    assert sniffed.returncode == 0, sniffed.stderr
    rotation = json.loads(sniffed.stdout)["rotation_us"]
    assert rotation["count"] >= rotations, rotation
    want = predicted["bus_cycle_us"]
    print("%s: validate %d us, status %.1f us, sniff %d us, %d idles of TID2 %d bits"
          % (name, want, bus_cycle, rotation["mean"], len(idles), tid2))
    assert abs(bus_cycle - want) <= 0.01 * want, (bus_cycle, want)
    assert abs(rotation["mean"] - want) <= 0.01 * want, (rotation, want)
    assert abs(rotation["mean"] - bus_cycle) <= 0.01 * want, (rotation, bus_cycle)
