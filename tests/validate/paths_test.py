#!/usr/bin/python3
"""Every JSON path `candp2 validate` (text and --json) and `candp2d --check` print can be pasted
into jq on the file they name (docs/validate.md "JSON paths"): each path resolves in that file,
key by key and index by index, to something the file holds.

Over every daemon configuration of config/ and tests/ (as validate_verdict finds them), the
configurations embedded in config/scenarios, and a set of broken ones made here from
config/line-1500k.json and config/line-9600.json (a missing key, an unknown key, a wrong type, a
value out of range, a watchdog or cycle too short for the line, a slave at a gateway's address).
Every file must get some path printed (a run that prints none proves nothing).

  paths_test.py --candp2d build/bin/candp2d --candp2 build/bin/candp2
"""

import argparse
import copy
import json
import os
import re
import subprocess
import sys
import tempfile

from verdict_test import ROOT, daemon_configurations

# "$", then .key, [3] or ["key with spaces"] (config/json_reader.cpp member()).
TOKEN = re.compile(r'\$(?:\.[A-Za-z_][A-Za-z0-9_]*|\[\d+\]|\["(?:[^"\\]|\\.)*"\])*')
STEP = re.compile(r'\.([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]|\[("(?:[^"\\]|\\.)*")\]')


def resolves(doc, path):
    """Whether every step of `path` exists in `doc` (what jq's getpath finds, not null)."""
    node = doc
    for key, index, quoted in STEP.findall(path[1:]):
        if quoted:
            key = json.loads(quoted)
        if key:
            if not isinstance(node, dict) or key not in node:
                return False
            node = node[key]
        else:
            if not isinstance(node, list) or int(index) >= len(node):
                return False
            node = node[int(index)]
    return True


def strings(value):
    """Every string in a JSON document (--json puts paths in values)."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from strings(v)


def printed_paths(candp2d, candp2, path):
    """(tool, path) for every JSON path the three runs print about `path`."""
    found = []
    for tool, argv in (("validate", [candp2, "validate", path]),
                       ("validate --json", [candp2, "validate", "--json", path]),
                       ("candp2d --check", [candp2d, "--check", "--config", path])):
        r = subprocess.run(argv, capture_output=True, text=True, timeout=60, cwd=ROOT)
        texts = [r.stdout + r.stderr]
        if tool == "validate --json" and r.stdout.strip():
            texts = list(strings(json.loads(r.stdout))) + [r.stderr]
        for text in texts:
            found.extend((tool, t) for t in TOKEN.findall(text) if t != "$")
    return found


def absolute_files(config, base):
    """The configuration with its relative file names (GSD files) absolute against `base`, so
    that a copy elsewhere loads the same files."""
    for s in config.get("slaves", []):
        if isinstance(s, dict) and isinstance(s.get("gsd"), str) and not os.path.isabs(s["gsd"]):
            s["gsd"] = os.path.normpath(os.path.join(base, s["gsd"]))
    return config


def broken(tmp):
    """Broken and warned-about variants of two shipped configurations, written to `tmp`."""
    def line(name):
        path = os.path.join(ROOT, "config", name)
        with open(path) as f:
            return absolute_files(json.load(f), os.path.dirname(path))

    def gw_parameters(c):
        return c["gateways"][0].setdefault("parameters", {})

    mutations = {
        "no-bus": ("line-1500k.json", lambda c: c["gateways"][0].pop("bus")),
        "no-slots": ("line-1500k.json", lambda c: c["gateways"][0].pop("slots")),
        "slot-without-io": ("line-1500k.json", lambda c: c["gateways"][0]["slots"][0].pop("io")),
        "unknown-key": ("line-1500k.json", lambda c: c["gateways"][0].update(bogus=1)),
        "baud-type": ("line-1500k.json", lambda c: c["master"].update(baud="fast")),
        "baud-value": ("line-1500k.json", lambda c: c["master"].update(baud=12345)),
        "slave-without-gsd": ("line-1500k.json", lambda c: c["slaves"][0].pop("gsd")),
        "slot-time": ("line-1500k.json",
                      lambda c: c["master"].setdefault("bus_parameters", {}).update(
                          slot_time_bits=1)),
        "address-taken": ("line-1500k.json", lambda c: c["slaves"][0].update(address=3)),
        "bus-type": ("line-1500k.json", lambda c: c["buses"]["can0"].update(type="x")),
        "watchdog": ("line-1500k.json", lambda c: gw_parameters(c).update(watchdog_ms=10)),
        "slave-watchdog": ("line-1500k.json", lambda c: c["slaves"][0].update(watchdog_ms=10)),
        # cycle_ms and the watchdogs left at their defaults: the paths still resolve.
        "defaults": ("line-9600.json", lambda c: [c["master"].pop("cycle_ms", None)] + [
            g.pop("parameters", None) for g in c["gateways"]]),
        "parameter-value": ("line-1500k.json", lambda c: gw_parameters(c).update(module_id=0)),
        "slave-parameter": ("line-1500k.json", lambda c: c["slaves"][0].update(
            parameters={"no such parameter": 1})),
    }
    made = []
    for name, (source, mutate) in mutations.items():
        c = copy.deepcopy(line(source))
        mutate(c)
        path = os.path.join(tmp, "broken-%s.json" % name)
        with open(path, "w") as f:
            json.dump(c, f, indent=1)
        made.append(path)
    return made


def embedded(tmp):
    """The configurations written into the scenarios of config/scenarios (not a file name)."""
    made = []
    folder = os.path.join(ROOT, "config", "scenarios")
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name)) as f:
            scenario = json.load(f)
        if isinstance(scenario.get("config"), dict):
            path = os.path.join(tmp, "scenario-" + name)
            with open(path, "w") as f:
                json.dump(absolute_files(scenario["config"], folder), f, indent=1)
            made.append(path)
    return made


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--candp2", required=True)
    args = ap.parse_args()
    failed = checked = 0
    with tempfile.TemporaryDirectory(prefix="candp2-paths-") as tmp:
        files = [os.path.join(ROOT, rel) for rel in daemon_configurations()]
        shipped = len(files)
        made = broken(tmp)
        files += embedded(tmp) + made
        for path in files:
            try:
                with open(path, encoding="utf-8") as f:
                    doc = json.load(f)
            except (ValueError, UnicodeDecodeError):
                continue  # no JSON: no path in it to resolve
            paths = printed_paths(args.candp2d, args.candp2, path)
            bad = sorted({(tool, p) for tool, p in paths if not resolves(doc, p)})
            checked += len(paths)
            rel = os.path.relpath(path, ROOT) if path.startswith(ROOT) else os.path.basename(path)
            if not paths:
                failed += 1
                print("FAIL: %s: no path printed at all" % rel)
            for tool, p in bad:
                failed += 1
                print("FAIL: %s: %s prints %s, which the file does not have" % (rel, tool, p))
            if not bad:
                print("ok: %s: %d paths resolve" % (rel, len(paths)))
    if shipped < 20 or checked < 500:
        print("FAIL: only %d shipped configurations, %d paths checked" % (shipped, checked))
        failed += 1
    print("%d paths in %d files checked, %d failures" % (checked, len(files), failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
