#!/usr/bin/python3
"""One verdict (docs/validate.md "One verdict"): for every daemon configuration in config/ and
tests/, `candp2d --check` and `candp2 validate` say the same: both accept it (exit 0), both find
a station that rejects it (exit 1), or both refuse it as unusable (exit 2).

  verdict_test.py --candp2d build/bin/candp2d --candp2 build/bin/candp2
"""

import argparse
import glob
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VERDICT = {0: "valid", 1: "invalid", 2: "unusable"}


def daemon_configurations():
    """Every JSON file of config/ and tests/ that is a daemon configuration: an object with
    gateways or slaves, not a replay scenario (steps) and not a golden or snapshot file."""
    found = []
    for path in sorted(glob.glob(os.path.join(ROOT, "config", "**", "*.json"), recursive=True) +
                       glob.glob(os.path.join(ROOT, "tests", "**", "*.json"), recursive=True)):
        rel = os.path.relpath(path, ROOT)
        if any(part in rel for part in ("golden", "snapshots", "corpus")):
            continue
        try:
            with open(path, encoding="utf-8") as f:
                doc = json.load(f)
        except (ValueError, UnicodeDecodeError):
            found.append(rel)  # a broken file: both must call it unusable
            continue
        if isinstance(doc, dict) and "steps" not in doc and ("gateways" in doc or "slaves" in doc):
            found.append(rel)
    return found


def run(argv):
    return subprocess.run(argv, capture_output=True, text=True, timeout=60, cwd=ROOT)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candp2d", required=True)
    ap.add_argument("--candp2", required=True)
    args = ap.parse_args()
    configs = daemon_configurations()
    failed = 0
    for rel in configs:
        check = run([args.candp2d, "--check", "--config", rel])
        validate = run([args.candp2, "validate", rel])
        a = VERDICT.get(check.returncode, "exit %d" % check.returncode)
        b = VERDICT.get(validate.returncode, "exit %d" % validate.returncode)
        if a != b:
            failed += 1
            print("FAIL: %s: candp2d --check says %s, candp2 validate says %s\n  --check: %s\n"
                  "  validate: %s" % (rel, a, b, (check.stdout + check.stderr).strip()[-600:],
                                      (validate.stdout + validate.stderr).strip()[-600:]))
        else:
            print("ok: %s: both %s" % (rel, a))
    if len(configs) < 20:
        print("FAIL: only %d configurations found" % len(configs))
        failed += 1
    print("%d passed, %d failed" % (len(configs) - failed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
