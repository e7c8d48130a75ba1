#!/usr/bin/python3
"""`candp2 validate`'s prediction of a CAN bus in time against the bus itself (docs/validate.md
"CAN buses", docs/can-bus.md "The bus in time"), the plant run in virtual time as replay runs it
(tests/validate/timed_bus_run.cpp), a writer changing every output every master cycle to the
longest data its frame can carry. One case per run:

  load     three configurations without overload whose traffic is fixed (config/timed-bus-250k-
           cyclic.json, timed-bus-500k-mixed.json, timed-bus-125k-slow.json), 10 s each: the
           bus's load (its last complete second and its most loaded one) within 2 % of
           validate's load_pct, nothing lost
  latency  config/timed-bus-500k-mixed.json for 600 s of virtual time: every identifier's largest
           queueing latency (send request to start of frame) at most validate's worst-case
           response time less the frame's transmission (the response counts from the release to
           the frame's end: less its own transmission it bounds request to start of frame)
"""
import argparse
import json
import subprocess
import sys

ARGS = None
LOAD_CONFIGS = ["timed-bus-250k-cyclic", "timed-bus-500k-mixed", "timed-bus-125k-slow"]


def fail(message):
    print("FAIL:", message, file=sys.stderr)
    sys.exit(1)


def run(cmd, timeout):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if r.returncode not in (0,):
        fail(f"{' '.join(cmd)}: exit {r.returncode}: {r.stdout} {r.stderr}")
    return r.stdout


def predicted(config):
    """validate --json's buses (exit 0: valid, no --strict)."""
    return json.loads(run([ARGS.candp2, "validate", "--json", config], 60))["buses"]


def measured(config, seconds):
    return json.loads(run([ARGS.timed_bus_run, config, str(seconds), "--writer", "longest"],
                          ARGS.timeout).splitlines()[-1])


def config_path(name):
    return f"{ARGS.source_dir}/config/{name}.json"


def case_load():
    for name in LOAD_CONFIGS:
        want = predicted(config_path(name))
        got = measured(config_path(name), 10)
        if set(want) != set(got["buses"]):
            fail(f"{name}: validate predicts buses {sorted(want)}, the plant has "
                 f"{sorted(got['buses'])}")
        for bus, p in want.items():
            m = got["buses"][bus]
            if p["problems"]:
                fail(f"{name}: validate reports problems on {bus}: {p['problems']}")
            if m["lost"]:
                fail(f"{name}: {m['lost']} frames lost on {bus}")
            for what in ("load_last_pct", "load_max_pct"):
                if abs(m[what] - p["load_pct"]) > 0.02 * p["load_pct"]:
                    fail(f"{name}: {bus} {what} {m[what]:.2f} %, validate predicts "
                         f"{p['load_pct']:.2f} % (more than 2 % apart)")
            print(f"load {name}: {bus} at {m['bitrate']} bit/s measured {m['load_last_pct']:.2f} % "
                  f"(max {m['load_max_pct']:.2f} %), validate {p['load_pct']:.2f} %: "
                  f"{100 * (m['load_last_pct'] / p['load_pct'] - 1):+.2f} %")


def bounds(bus):
    """{(id, extended, remote): queueing bound in us} from validate's identifiers: the largest
    response less transmission over the messages of the identifier (a Tx slot's outputs and its
    cycle are two messages of one identifier)."""
    out = {}
    for m in bus["identifiers"]:
        key = (int(m["can_id"], 16), m["extended"], m["remote"])
        bound = None if m["response_us"] is None else m["response_us"] - m["transmission_us"]
        if key in out and (out[key] is None or bound is None):
            out[key] = None
        else:
            out[key] = bound if key not in out else max(out[key], bound)
    return out


def case_latency():
    name = "timed-bus-500k-mixed"
    want = predicted(config_path(name))
    got = measured(config_path(name), ARGS.seconds)
    for bus, p in want.items():
        b = bounds(p)
        m = got["buses"][bus]
        if m["lost"]:
            fail(f"{name}: {m['lost']} frames lost on {bus}")
        worst = []
        for i in m["identifiers"]:
            key = (i["id"], i["extended"], i["remote"])
            if key not in b:
                fail(f"{name}: identifier 0x{i['id']:X} on the bus, not in validate's prediction")
            if b[key] is None:
                fail(f"{name}: validate gives 0x{i['id']:X} no bound")
            if i["latency_max_us"] > b[key]:
                fail(f"{name}: 0x{i['id']:X} waited up to {i['latency_max_us']} us from request "
                     f"to start of frame, validate's bound is {b[key]:.1f} us")
            worst.append((i["latency_max_us"] / b[key], i["id"], i["latency_max_us"], b[key],
                          i["frames"]))
        worst.sort(reverse=True)
        print(f"latency {name}: {bus}, {ARGS.seconds} s of virtual time, {m['frames']} frames, "
              f"{len(worst)} identifiers, each within its bound; the closest: " +
              ", ".join(f"0x{i:X} {lat} us of {bound:.0f} us ({frames} frames)"
                        for _, i, lat, bound, frames in worst[:3]))


def main():
    global ARGS
    ap = argparse.ArgumentParser()
    ap.add_argument("case", choices=["load", "latency"])
    ap.add_argument("--candp2", required=True)
    ap.add_argument("--timed-bus-run", required=True)
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--seconds", type=int, default=600)
    ap.add_argument("--timeout", type=int, default=240)
    ARGS = ap.parse_args()
    {"load": case_load, "latency": case_latency}[ARGS.case]()
    print(ARGS.case + ": ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
