#!/usr/bin/python3
"""The Wireshark dissector (tools/wireshark/candp2.lua) with Debian's tshark on captures candp2's
own code writes (docs/capture.md "Tests"). One case per run:

  demo        demo_capture's README walk-through: in time order the Data_Exchange carrying
              51 00 00 .., the CAN frame 0x201 51 00 00 00 00, then after the read command the
              drive's reply on 0x181, and the gateway's input slot showing it
  malformed   demo_capture --frames 100000: no packet marked malformed or with an expert info of
              severity error, and every decoder path present (faults, bus state, notes)
  sniff-file  candp2 sniff --pcapng of tests/sniff/spec10.bin (a real master parameterizing
              slave 3, with line noise; tests/sniff/make_capture.py): Set_Prm ident 04A4 and the user parameters, the Chk_Cfg slots, the FCS error
  sniff-pty   the same telegrams written into candp2 sniff's pty:PATH, captured as they arrive
  daemon-demo candp2d itself with a "capture" section on config/demo.json, driven over Modbus as
              the README's walk-through: the same timeline as the demo case, from the daemon
  daemon-slaves candp2d in profibus role slaves on a pty with a capture; a master writes the
              spec's telegrams: Set_Prm ident 04A4 and the Chk_Cfg slots decoded, both directions
  timed-line  demo_capture --baud 187500 (docs/profibus.md "The line in time"): telegrams never
              overlap, TSYN before every request, min_TSDR before every answer
  timed-can   demo_capture --config of buses in time (docs/can-bus.md "The bus in time"): the
              CAN interface's if_speed is the bit rate; consecutive frames never overlap, each
              starts at least the exact length of the one before later (lengths computed here, not
              by candp2); the load of each second computed from the capture equals the bus's
  timed-can-errors  demo_capture --config config/timed-bus-alone.json (docs/capture.md "Error
              frames"): a lone gateway's ACK errors as SocketCAN error frames, as many as the
              bus's error_frames; its warning at TEC 96 and error passive at TEC 128 as controller
              error frames; no frame gets through

Every tshark run is bounded (timeout) and checks that the Lua script loaded without an error.
"""
import argparse
import json
import os
import select
import subprocess
import sys
import tempfile
import time
import tty

ARGS = None


def fail(message):
    print("FAIL:", message, file=sys.stderr)
    sys.exit(1)


def tshark(capture, *extra, timeout=240):
    cmd = [ARGS.tshark, "-X", "lua_script:" + ARGS.lua, "-r", capture, *extra]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    errors = [l for l in r.stderr.splitlines() if "Lua" in l or "rror" in l]
    if r.returncode != 0 or errors:
        fail(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr}")
    return r.stdout


def fields(capture, names, display_filter=None):
    """Rows of -T fields output as dicts (empty fields are "")."""
    extra = ["-T", "fields", "-E", "separator=\t", "-E", "occurrence=a", "-E", "aggregator=,"]
    for n in names:
        extra += ["-e", n]
    if display_filter:
        extra += ["-Y", display_filter]
    rows = []
    for line in tshark(capture, *extra).splitlines():
        parts = line.split("\t")
        parts += [""] * (len(names) - len(parts))
        rows.append(dict(zip(names, parts)))
    return rows


def count(capture, display_filter):
    return len(tshark(capture, "-Y", display_filter, "-T", "fields", "-e", "frame.number")
               .splitlines())


def run(cmd, timeout=300):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        fail(f"{' '.join(cmd)}: exit {r.returncode}: {r.stdout} {r.stderr}")
    return r.stdout


def first(rows, start, pred):
    for i in range(start, len(rows)):
        if pred(rows[i]):
            return i
    return None


def case_demo(tmp):
    cap = os.path.join(tmp, "demo.pcapng")
    run([ARGS.demo_capture, cap])
    check_demo(cap, notes=True, changed=["000000", "510000", "3da864", "316626"], least=500)


def check_demo(cap, notes, changed, least):
    """The README walk-through in time order; `changed`: the output bytes of the Data_Exchanges
    whose data changed (dp.changed), `notes`: the capture carries the walk-through's notes."""
    names = ["frame.number", "frame.time_epoch", "dp.service", "dp.response", "dp.outputs",
             "dp.inputs", "can.id", "data.data", "candp2.can.data", "candp2.can.station",
             "candp2.note"]
    rows = fields(cap, names)
    for r in rows:  # a CAN frame's payload: the dissector's view of a slot's frame, else data
        r["payload"] = r["candp2.can.data"] or r["data.data"]
    if len(rows) < least:
        fail(f"only {len(rows)} packets")
    times = [float(r["frame.time_epoch"]) for r in rows]
    if times != sorted(times):
        fail("packets are not in time order")
    # dp.service 1 = Data_Exchange (candp2.lua); a request has dp.response False ("0").
    dx_req = first(rows, 0, lambda r: r["dp.service"] == "1" and r["dp.response"] == "0"
                   and r["dp.outputs"].startswith("510000"))
    if dx_req is None:
        fail("no Data_Exchange carrying 51 00 00")
    can_201 = first(rows, dx_req, lambda r: r["can.id"] == "513"
                    and r["payload"] == "5100000000" and r["candp2.can.station"] == "3")
    if can_201 is None:
        fail("no CAN frame 0x201 51 00 00 00 00 after the Data_Exchange")
    read_cmd = first(rows, can_201, lambda r: r["can.id"] == "513"
                     and r["payload"].startswith("3da864"))
    if read_cmd is None:
        fail("no read command 0x201 3D A8 64 after the enable")
    reply = first(rows, read_cmd, lambda r: r["can.id"] == "385"
                  and r["payload"].startswith("a8"))
    if reply is None:
        fail("no drive reply on 0x181 after the read command")
    shown = first(rows, reply, lambda r: r["dp.service"] == "1" and r["dp.response"] == "1"
                  and r["dp.inputs"].startswith("a8"))
    if shown is None:
        fail("the gateway's inputs never show the drive's reply")
    if notes and not any("enable axis1" in r["candp2.note"] for r in rows[:dx_req + 1]):
        fail("the step note before the Data_Exchange is missing")
    print(f"demo: Data_Exchange 51 00 00 in frame {rows[dx_req]['frame.number']}, CAN 0x201 in "
          f"{rows[can_201]['frame.number']}, read command in {rows[read_cmd]['frame.number']}, "
          f"reply 0x181 in {rows[reply]['frame.number']}, inputs A8 in "
          f"{rows[shown]['frame.number']}")
    # The Chk_Cfg slots with the gateway's meaning, and the display filters docs/capture.md names.
    slots = fields(cap, ["candp2.slot.id", "candp2.slot.kind"], "dp.service == Chk_Cfg")
    if not slots or slots[0]["candp2.slot.id"] != "0x00000201,0x00000202,0x00000181,0x00000182" \
            or slots[0]["candp2.slot.kind"] != "tx,tx,rx,rx":
        fail(f"Chk_Cfg slots: {slots[:1]}")
    # dp.changed: only the exchanges whose data changed (the timeline of docs/capture.md).
    rows_changed = fields(cap, ["dp.outputs"], "dp.changed && dp.response == 0")
    outs = [r["dp.outputs"][:6] for r in rows_changed]
    if outs != changed:
        fail(f"changed outputs: {outs}")
    filters = ["fdl.da == 3 && dp.service == Set_Prm", "fdl.fc.fcb == 1", "candp2.slot.id == 0x201",
               "can.id == 0x181", "candp2.prm.bitrate == 2",
               "candp2.note || can || dp.service != Data_Exchange || dp.changed"]
    if notes:
        filters.append("frame.comment contains \"axis1\"")
    for f in filters:
        if count(cap, f) == 0:
            fail(f"display filter {f!r} matches nothing")


def case_timed_line(tmp):
    """docs/profibus.md "The line in time": the demo walk-through on a 187.5 kbit/s line. Each
    telegram is stamped with its first character: consecutive telegrams never overlap, the idle
    before a request or token is at least TSYN (33 bit times), an answer starts no earlier than
    min_TSDR (11 bit times) after its request's last character."""
    baud = 187500
    cap = os.path.join(tmp, "timed.pcapng")
    run([ARGS.demo_capture, cap, "--baud", str(baud)])
    rows = fields(cap, ["frame.time_epoch", "fdl.sd", "fdl.le", "fdl.fc.req"], "fdl")
    if len(rows) < 200:
        fail(f"only {len(rows)} telegrams")
    chars = {"0x10": lambda r: 6, "0x68": lambda r: int(r["fdl.le"]) + 6, "0xa2": lambda r: 14,
             "0xdc": lambda r: 3, "0xe5": lambda r: 1}
    bit = 1.0 / baud
    slack = 1e-6  # stamps are whole microseconds, rounded up from the bit
    prev_end, prev_request = None, None
    tokens = 0
    for r in rows:
        t = float(r["frame.time_epoch"])
        length = chars[r["fdl.sd"]](r) * 11 * bit
        request = r["fdl.sd"] == "0xdc" or r["fdl.fc.req"] in ("1", "True")
        tokens += r["fdl.sd"] == "0xdc"
        if prev_end is not None:
            idle = t - prev_end
            if idle < -slack:
                fail(f"telegram at {t:.6f} overlaps the one before (ends {prev_end:.6f})")
            if request and idle < 33 * bit - slack:
                fail(f"request at {t:.6f}: idle {idle * 1e6:.1f} us < TSYN")
            if not request and prev_request and idle < 11 * bit - slack:
                fail(f"answer at {t:.6f}: {idle * 1e6:.1f} us after its request < min_TSDR")
        prev_end, prev_request = t + length, request
    if tokens == 0:
        fail("no token (SD4) on the line")
    print(f"timed-line: {len(rows)} telegrams, {tokens} tokens, no overlap, TSYN and min_TSDR kept")


def can_frame_bits(ident, ext, rtr, dlc, data):
    """docs/can-bus.md "Frames on the wire", written again here so that the test does not share
    candp2's arithmetic: the bits from start of frame through the CRC (CRC-15, polynomial 0x4599),
    the stuff bits on that stream (after five equal bits one complementary bit, which starts the
    next run), and the 13 unstuffed trailer bits through the intermission."""
    def bits_of(value, n):
        return [(value >> i) & 1 for i in range(n - 1, -1, -1)]
    bits = [0]
    if ext:
        bits += bits_of(ident >> 18, 11) + [1, 1] + bits_of(ident & 0x3FFFF, 18) + [rtr, 0, 0]
    else:
        bits += bits_of(ident, 11) + [rtr, 0, 0]
    bits += bits_of(dlc, 4)
    if not rtr:
        for byte in data[:min(dlc, 8)]:
            bits += bits_of(byte, 8)
    crc = 0
    for b in bits:
        top = ((crc >> 14) & 1) ^ b
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= 0x4599
    bits += bits_of(crc, 15)
    stuff, last, run = 0, None, 0
    for b in bits:
        run = run + 1 if b == last else 1
        last = b
        if run == 5:
            stuff += 1
            last, run = 1 - b, 1
    return len(bits) + stuff + 13


def check_can_frame_bits():
    """The frames docs/can-bus.md's unit tests work by hand: this copy must agree with them."""
    counting = [0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]
    cases = [((0x000, 0, 0, 0, []), 53), ((0x080, 0, 0, 0, []), 51),
             ((0x123, 0, 0, 8, counting), 112), ((0x7FF, 0, 0, 8, [0xFF] * 8), 126),
             ((0x123, 0, 1, 4, []), 47), ((0x12345678, 1, 0, 0, []), 69),
             ((0x1FFFFFFF, 1, 1, 8, []), 74), ((0, 1, 0, 8, [0] * 8), 150)]
    for args, bits in cases:
        if can_frame_bits(*args) != bits:
            fail(f"the test's frame length of {args} is {can_frame_bits(*args)}, not {bits}")


def if_speeds(capture):
    """{interface name: if_speed or None} from the capture's Interface Description Blocks."""
    raw = open(capture, "rb").read()
    speeds, pos = {}, 0
    while pos + 12 <= len(raw):
        kind, length = int.from_bytes(raw[pos:pos + 4], "little"), \
            int.from_bytes(raw[pos + 4:pos + 8], "little")
        if kind == 1:  # IDB: link type, reserved, snap length, then the options
            opt, name, speed = pos + 16, None, None
            while opt + 4 <= pos + length - 4:
                code = int.from_bytes(raw[opt:opt + 2], "little")
                size = int.from_bytes(raw[opt + 2:opt + 4], "little")
                value = raw[opt + 4:opt + 4 + size]
                if code == 0:
                    break
                if code == 2:
                    name = value.decode()
                if code == 8:
                    speed = int.from_bytes(value, "little")
                opt += 4 + (size + 3) // 4 * 4
            speeds[name] = speed
        pos += length
    return speeds


def case_timed_can_errors(tmp):
    """docs/capture.md "Error frames": config/timed-bus-alone.json's gateway alone on its bus in
    time, nobody acknowledging: every attempt is an ACK error written as a SocketCAN error frame
    (CAN_ERR_FLAG, CAN_ERR_ACK, location ACK slot), as many as the bus counted; its state changes as
    controller error frames with the counters in data[6..7]: TX warning at TEC 96, TX passive at
    TEC 128, never bus-off; no data frame."""
    cap = os.path.join(tmp, "alone.pcapng")
    out = run([ARGS.demo_capture, cap, "--config",
               os.path.join(ARGS.source_dir, "config", "timed-bus-alone.json"), "--seconds", "2"])
    st = json.loads(out.splitlines()[-1])["buses"]["can0"]
    if st["error_frames"] < 100 or st["frames"] != 0:
        fail(f"timed-bus-alone: the bus counted {st['error_frames']} error frames and "
             f"{st['frames']} frames, want ACK errors only")
    acks = count(cap, 'frame.interface_name == "can0" && can.flags.err && can.err.ack == 1 '
                      '&& can.err.prot.location == 0x19')
    if acks != st["error_frames"]:
        fail(f"timed-bus-alone: {acks} ACK error frames in the capture, the bus counted "
             f"{st['error_frames']}")
    if count(cap, "can && !can.flags.err"):
        fail("timed-bus-alone: a data frame got through in the capture")
    states = fields(cap, ["can.err.ctrl.tx_warning", "can.err.ctrl.tx_passive",
                          "can.err.ctrl_specific"], "can.err.ctrl == 1")
    got = [(r["can.err.ctrl.tx_warning"], r["can.err.ctrl.tx_passive"],
            r["can.err.ctrl_specific"].replace(":", "").replace(" ", "")) for r in states]
    # ctrl_specific: data[5..7]; TEC in data[6].
    want = [("1", "0", "006000"), ("0", "1", "008000")]
    if [(w in ("1", "True"), p in ("1", "True"), d) for w, p, d in got] != \
            [(w == "1", p == "1", d) for w, p, d in want]:
        fail(f"timed-bus-alone: controller error frames {got}, want TX warning at TEC 96 then "
             f"TX passive at TEC 128")
    if count(cap, "can.err.busoff == 1"):
        fail("timed-bus-alone: bus-off in the capture, the gateway only goes error passive")
    print(f"timed-can-errors: {acks} ACK error frames = the bus's error_frames, TX warning at TEC "
          f"96 and TX passive at TEC 128, no data frame")


def case_timed_can(tmp):
    """docs/can-bus.md "The bus in time" seen in a capture: every CAN frame stamped at its start of
    frame (whole microseconds, the first at or after its bit), the interface's if_speed the bus's
    bit rate. Consecutive frames never overlap: each starts at least the exact length of the one
    before later. The load of each second computed from the capture's frames at their exact
    lengths equals the bus's own (its last complete second and its most loaded) within 1 %.
    Overloaded (timed-bus-125k, back to back) and loaded with drives' replies (timed-bus-drive)."""
    check_can_frame_bits()
    seconds = 4
    for name in ("timed-bus-125k", "timed-bus-drive"):
        cap = os.path.join(tmp, name + ".pcapng")
        out = run([ARGS.demo_capture, cap, "--config",
                   os.path.join(ARGS.source_dir, "config", name + ".json"),
                   "--seconds", str(seconds)])
        stats = json.loads(out.splitlines()[-1])["buses"]
        speeds = if_speeds(cap)
        for bus, st in stats.items():
            rate = st["bitrate"]
            if speeds.get(bus) != rate:
                fail(f"{name}: interface {bus} states if_speed {speeds.get(bus)}, want {rate}")
            rows = fields(cap, ["frame.time_epoch", "can.id", "can.flags.xtd", "can.flags.rtr",
                                "can.len", "data.data", "candp2.can.data"],
                          f'frame.interface_name == "{bus}"')
            if len(rows) != st["frames"]:
                fail(f"{name}: {len(rows)} frames in the capture, the bus counted {st['frames']}")
            bit = 1.0 / rate
            origin = None
            prev_start, prev_bits = None, 0
            busy = [0.0] * (seconds + 1)  # bit times per second of bus time
            tightest = None
            for r in rows:
                t = float(r["frame.time_epoch"])
                # The epoch of demo_capture's plant time 0, the bus's origin (docs/can-bus.md "In
                # the plant": timed from the plant's start).
                origin = origin if origin is not None else int(t)
                # The payload: Wireshark's data, or the dissector's on a slot's identifier (one
                # per slot that uses it: the first).
                payload = (r["candp2.can.data"] or r["data.data"]).split(",")[0]
                data = bytes.fromhex(payload.replace(":", ""))
                rtr = r["can.flags.rtr"] in ("1", "True")
                nbits = can_frame_bits(int(r["can.id"]), r["can.flags.xtd"] in ("1", "True"),
                                       int(rtr), int(r["can.len"]), list(data))
                if prev_start is not None:
                    gap = t - prev_start - prev_bits * bit
                    # Stamps are whole microseconds rounded up from the bit: 1 us of slack.
                    if gap < -1.0e-6:
                        fail(f"{name}: frame 0x{int(r['can.id']):X} at {t:.6f} starts "
                             f"{-gap * 1e6:.1f} us before the frame before it ends")
                    tightest = gap if tightest is None else min(tightest, gap)
                start = (t - origin) * rate  # in bit times from the origin (to 1 us)
                end = start + nbits
                for sec in range(int(start // rate), min(int(end // rate), seconds) + 1):
                    busy[sec] += max(0.0, min(end, (sec + 1) * rate) - max(start, sec * rate))
                prev_start, prev_bits = t, nbits
            loads = [100.0 * b / rate for b in busy[:seconds]]
            for what, mine, theirs in (("last", loads[-1], st["load_last_pct"]),
                                       ("max", max(loads), st["load_max_pct"])):
                if abs(mine - theirs) > 1.0:
                    fail(f"{name}: load {what} from the capture {mine:.2f} %, the bus's "
                         f"{theirs:.2f} %")
            print(f"timed-can {name}: {len(rows)} frames on {bus} at {rate} bit/s, none "
                  f"overlapping (tightest gap {tightest * 1e6:.1f} us), load per second from the "
                  f"capture {[round(x, 2) for x in loads]} %, the bus's last "
                  f"{st['load_last_pct']:.2f} % max {st['load_max_pct']:.2f} %")


PI_ERROR = 0x00800000  # Wireshark's expert severity "error" (epan/proto.h PI_ERROR)


def case_malformed(tmp):
    cap = os.path.join(tmp, "long.pcapng")
    out = run([ARGS.demo_capture, cap, "--frames", "100000"])
    # The packet count without the dissector (fast), then one pass with it.
    total = len(run([ARGS.tshark, "-r", cap, "-T", "fields", "-e", "frame.number"]).splitlines())
    if total < 100000:
        fail(f"only {total} packets ({out.strip()})")
    bad = "_ws.malformed || _ws.expert.severity >= error"
    # Not vacuous: every path of the gateway's payloads occurs (faults, bus state, notes, slots).
    wanted = ["candp2.diag.cfg_code == 4", "candp2.diag.prm_byte == 8",
              "candp2.diag.bus_state == 0x40", "candp2.note contains \"power cycle\"",
              "dp.service == FDL_Status", "candp2.slot.data && frame.number < 1000",
              "can.id == 0x181 && frame.number < 1000"]
    names = ["frame.number", "_ws.malformed", "_ws.expert.severity", "candp2.diag.cfg_code",
             "candp2.diag.prm_byte", "candp2.diag.bus_state", "candp2.note", "dp.service",
             "candp2.slot.data", "can.id"]
    rows = fields(cap, names, "(" + bad + ") || " + " || ".join("(" + w + ")" for w in wanted))
    marked = [r["frame.number"] for r in rows if r["_ws.malformed"] or any(
        int(v, 0) >= PI_ERROR for v in r["_ws.expert.severity"].split(",") if v)]
    if marked:
        fail(f"{len(marked)} packets match {bad!r}, e.g. frames {marked[:10]}")
    seen = {
        wanted[0]: any(r["candp2.diag.cfg_code"] == "4" for r in rows),
        wanted[1]: any(r["candp2.diag.prm_byte"] == "8" for r in rows),
        wanted[2]: any(r["candp2.diag.bus_state"] == "0x40" for r in rows),
        wanted[3]: any("power cycle" in r["candp2.note"] for r in rows),
        wanted[4]: any(r["dp.service"] == "2" for r in rows),
        wanted[5]: any(r["candp2.slot.data"] for r in rows),
        wanted[6]: any(r["can.id"] == "385" for r in rows),
    }
    missing = [w for w, ok in seen.items() if not ok]
    if missing:
        fail(f"never occurs: {missing}")
    print(f"malformed: {total} packets, none matches {bad!r}")


def check_spec_capture(cap, expect_errors):
    prm = fields(cap, ["dp.prm.ident", "candp2.prm.bitrate", "candp2.prm.module_id"],
                 "dp.service == Set_Prm && dp.response == 0")
    if [r["dp.prm.ident"] for r in prm] != ["0x04a4"] or prm[0]["candp2.prm.bitrate"] != "2" \
            or prm[0]["candp2.prm.module_id"] != "1":
        fail(f"Set_Prm: {prm}")
    cfg = fields(cap, ["candp2.slot.id", "candp2.slot.kind", "candp2.slot.form",
                       "candp2.slot.offset"], "dp.service == Chk_Cfg && dp.response == 0")
    want = {"candp2.slot.id": "0x00000289,0x00000309", "candp2.slot.kind": "rx,tx",
            "candp2.slot.form": "0xb8,0xb8", "candp2.slot.offset": "0,0"}
    if cfg != [want]:
        fail(f"Chk_Cfg slots: {cfg}")
    sc = fields(cap, ["fdl.request_in"], "fdl.sd == 0xe5 && dp.service == Set_Prm")
    if len(sc) != 1 or not sc[0]["fdl.request_in"]:
        fail(f"the SC after Set_Prm is not tied to its request: {sc}")
    fcs_bad = count(cap, "fdl.fcs.bad")
    if fcs_bad != (1 if expect_errors else 0):
        fail(f"{fcs_bad} telegrams with a bad FCS")
    print(f"Set_Prm ident 04A4, slots 289 rx / 309 tx form B8, {fcs_bad} bad FCS")


def case_sniff_file(tmp):
    # A capture file in a directory that does not exist: exit 2 before reading, saying why.
    missing = os.path.join(tmp, "no-such-dir", "x.pcapng")
    r = subprocess.run([ARGS.candp2, "sniff", "--pcapng", missing,
                        os.path.join(ARGS.source_dir, "tests", "sniff", "spec10.bin")],
                       capture_output=True, text=True, timeout=30)
    if r.returncode != 2 or "does not exist" not in r.stderr or r.stdout:
        fail(f"sniff --pcapng {missing}: exit {r.returncode}: {r.stdout} {r.stderr}")
    cap = os.path.join(tmp, "spec10.pcapng")
    run([ARGS.candp2, "sniff", "--pcapng", cap,
         os.path.join(ARGS.source_dir, "tests", "sniff", "spec10.bin")])
    check_spec_capture(cap, True)
    # The filter of the malformed case does find what is wrong on a line.
    marked = count(cap, "_ws.malformed || _ws.expert.severity >= error")
    if marked != 3:
        fail(f"{marked} packets marked as errors, expected the FCS, LE and truncated ones")
    comments = fields(cap, ["frame.comment"], "frame.comment")
    texts = [r["frame.comment"] for r in comments]
    if texts != ["candp2 sniff: FCS wrong", "candp2 sniff: LE != LEr",
                 "candp2 sniff: truncated telegram"]:
        fail(f"comments of the abandoned candidates: {texts}")


# The capture of tests/sniff/make_capture.py: master 2 parameterizing slave 3.
SPEC_TELEGRAMS = [
    "10 03 02 49 4E 16", "10 02 03 00 05 16",
    "68 05 05 68 83 82 6D 3C 3E EC 16",
    "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16",
    "68 15 15 68 83 82 5D 3D 3E 88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF 2C 16", "E5",
    "68 0F 0F 68 83 82 7D 3E 3E 43 85 02 89 B8 83 85 03 09 B8 D5 16", "E5",
    "68 05 05 68 83 82 5D 3C 3E DC 16",
    "68 10 10 68 82 83 08 3E 3C 00 0C 00 02 04 A4 05 04 00 00 00 46 16",
    "68 09 09 68 03 02 7D 11 22 33 44 55 66 E7 16",
    "68 09 09 68 02 03 08 00 00 00 00 00 00 0D 16",
]


def case_sniff_pty(tmp):
    cap = os.path.join(tmp, "pty.pcapng")
    link = os.path.join(tmp, "line")
    proc = subprocess.Popen([ARGS.candp2, "sniff", "--pcapng", cap, "-n", str(len(SPEC_TELEGRAMS)),
                             "--baud", "19200", "pty:" + link],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 10
        while not os.path.islink(link):
            if proc.poll() is not None or time.monotonic() > deadline:
                fail(f"sniffer did not create {link}: {proc.stderr.read()}")
            time.sleep(0.01)
        fd = os.open(link, os.O_RDWR | os.O_NOCTTY)
        for telegram in SPEC_TELEGRAMS:
            os.write(fd, bytes.fromhex(telegram))
            time.sleep(0.05)  # > TSYN at 19200 baud: each write is one telegram
        out, err = proc.communicate(timeout=10)
        os.close(fd)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if proc.returncode != 0 or len(out.splitlines()) != len(SPEC_TELEGRAMS):
        fail(f"sniff exit {proc.returncode}: {out} {err}")
    check_spec_capture(cap, False)
    rel = [float(r["frame.time_relative"]) for r in fields(cap, ["frame.time_relative"])]
    if len(rel) != len(SPEC_TELEGRAMS) or rel[-1] < 0.04 * (len(rel) - 1):
        fail(f"time stamps do not follow the arrival: {rel}")


def daemon(config, tmp):
    """candp2d on `config` through the candp2 package (free ports, READY=1)."""
    import candp2  # python/ (PYTHONPATH), Debian's pymodbus
    return candp2.Daemon(config, ARGS.candp2d, timeout=30)


def case_daemon_demo(tmp):
    cap = os.path.join(tmp, "daemon.pcapng")
    with open(os.path.join(ARGS.source_dir, "config", "demo.json")) as f:
        config = json.load(f)
    config["capture"] = {"pcapng": cap}
    with daemon(config, tmp) as d:
        gw = d.gateway(3)
        # In Data_Exch with the release frames out (a write before the first Data_Exchange would
        # go out as the release frame itself).
        gw.wait_until(lambda g: g.state == "Data_Exch" and g.counters.tx_frames >= 2, timeout=10)
        # The README's writes: holding registers 0..2 = Q 0..5.
        gw.outputs[0:6] = bytes.fromhex("51 00 00 00 00 00")  # enable axis1
        gw.wait_until(lambda g: g.counters.tx_frames >= 3, timeout=10)
        gw.outputs[0:6] = bytes.fromhex("3D A8 64 00 00 00")  # read speed every 100 ms
        gw.wait_until(lambda g: g.inputs[0] == 0xA8, timeout=10)
    check_demo(cap, notes=False, changed=["000000", "510000", "3da864"], least=20)


def case_daemon_slaves(tmp):
    cap = os.path.join(tmp, "line.pcapng")
    link = os.path.join(tmp, "pb")
    with open(os.path.join(ARGS.source_dir, "config", "example.json")) as f:
        example = json.load(f)
    gateway = example["gateways"][0]  # the manual §5.1.4 slots at DP address 3
    gateway["address"] = 3
    config = {"profibus": {"port": "pty:" + link, "baud": 19200, "role": "slaves"},
              "buses": {"can0": {"type": "virtual"}}, "gateways": [gateway],
              "capture": {"pcapng": cap}}
    with daemon(config, tmp) as d:
        fd = os.open(link, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(fd)
            for telegram in SPEC_TELEGRAMS:
                raw = bytes.fromhex(telegram)
                if raw[0] == 0xE5 or (raw[0] == 0x10 and raw[1] == 0x02) or \
                        (raw[0] == 0x68 and raw[4] & 0x7F == 0x02):
                    continue  # an answer of the spec's slave: candp2d gives its own
                os.write(fd, raw)
                deadline = time.monotonic() + 2
                answer = b""
                while not (answer and answer[-1] in (0x16, 0xE5)):
                    left = deadline - time.monotonic()
                    if left <= 0 or not select.select([fd], [], [], left)[0]:
                        break
                    answer += os.read(fd, 256)
                if not answer:
                    fail(f"no answer to {telegram}")
        finally:
            os.close(fd)
        del d  # stopped by the with block: the capture is complete
    check_spec_capture(cap, False)
    # Both directions: the master's request as received, candp2d's short acknowledge as sent.
    both = fields(cap, ["fdl.sd", "fdl.sa"], "dp.service == Chk_Cfg")
    if [(r["fdl.sd"], r["fdl.sa"]) for r in both] != [("0x68", "2"), ("0xe5", "")]:
        fail(f"Chk_Cfg request and answer: {both}")


def case_daemon_line_faults(tmp):
    """docs/faults.md "Line faults": candp2d on config/line-1500k.json, faults on cue through the
    candp2 package (5 corrupt answers of station 3, station 4 silent for 2 requests), captured.
    tshark with the dissector flags exactly the 5 corrupt answers (wrong FCS) and nothing else is
    malformed; `candp2 sniff --stats --json` on the capture counts what candp2d counted."""
    cap = os.path.join(tmp, "line.pcapng")
    with open(os.path.join(ARGS.source_dir, "config", "line-1500k.json")) as f:
        config = json.load(f)
    for s in config["slaves"]:  # the configuration is written elsewhere: its GSD by full path
        s["gsd"] = os.path.join(ARGS.source_dir, "config", s["gsd"])
    config["capture"] = {"pcapng": cap}
    with daemon(config, tmp) as d:
        def station(a):
            return d.line.station(a)
        gw, io = d.gateway(3), d.slave(4)
        gw.wait_until(lambda g: g.master_state == "Data_Exch", timeout=10)
        io.wait_until(lambda s: s.master_state == "Data_Exch", timeout=10)
        start3, start4 = station(3), station(4)
        d.line.inject(3, "corrupt", count=5, every=2)
        gw.wait_until(lambda _: station(3).illegals == start3.illegals + 5, timeout=10)
        d.line.inject(4, "silent", count=2)
        io.wait_until(lambda _: station(4).syncs == start4.syncs + 1
                      and station(4).live == "ok", timeout=10)
        io.wait_until(lambda s: s.master_state == "Data_Exch", timeout=10)
        time.sleep(0.2)  # a few quiet cycles: the counters stand still from here
        ours = {a: station(a) for a in (3, 4)}
        if ours[3].repeats != start3.repeats + 5 or ours[4].lost != start4.lost + 1:
            fail(f"candp2d's counters: {ours}")
    bad = count(cap, "fdl.fcs.bad")
    if bad != 5:
        fail(f"{bad} telegrams with a wrong FCS flagged, want the 5 corrupt answers")
    rows = fields(cap, ["frame.number", "_ws.malformed", "_ws.expert.severity", "fdl.fcs.bad"],
                  "_ws.malformed || _ws.expert.severity >= error")
    other = [r["frame.number"] for r in rows if not r["fdl.fcs.bad"]]
    if other:
        fail(f"frames marked malformed or in error besides the corrupt answers: {other[:10]}")
    sniff = json.loads(run([ARGS.candp2, "sniff", "--stats", "--json", cap]).splitlines()[-1])
    theirs = {s["address"]: s for s in sniff["stations"]}
    for a, mine in ours.items():
        for name, value in mine.counters.items():
            if theirs[a][name] != value:
                fail(f"station {a} {name}: candp2d {value}, sniff --stats {theirs[a][name]}")
        if theirs[a]["live"] != mine.live:
            fail(f"station {a} live: candp2d {mine.live}, sniff --stats {theirs[a]['live']}")
    print(f"daemon-line-faults: 5 corrupt answers flagged, nothing else; sniff --stats agrees "
          f"with candp2d on stations 3 and 4 ({ {a: dict(m.counters) for a, m in ours.items()} })")


def main():
    global ARGS
    ap = argparse.ArgumentParser()
    ap.add_argument("case", choices=["demo", "malformed", "sniff-file", "sniff-pty",
                                     "daemon-demo", "daemon-slaves", "timed-line",
                                     "daemon-line-faults", "timed-can", "timed-can-errors"])
    ap.add_argument("--candp2d")
    ap.add_argument("--tshark", default="tshark")
    ap.add_argument("--lua", required=True)
    ap.add_argument("--demo-capture", required=True)
    ap.add_argument("--candp2", required=True)
    ap.add_argument("--source-dir", required=True)
    ARGS = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        {"demo": case_demo, "malformed": case_malformed, "sniff-file": case_sniff_file,
         "sniff-pty": case_sniff_pty, "daemon-demo": case_daemon_demo,
         "daemon-slaves": case_daemon_slaves, "timed-line": case_timed_line,
         "daemon-line-faults": case_daemon_line_faults, "timed-can": case_timed_can,
         "timed-can-errors": case_timed_can_errors}[ARGS.case](tmp)
    print(ARGS.case + ": ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
