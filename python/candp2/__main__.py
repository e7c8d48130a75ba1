"""`python3 -m candp2 map [--binary PATH] [--config FILE] [--shell] [--output FILE]`: candp2d's
Modbus map (its `--print-modbus-map --json`) as JSON, or as shell assignments for scripts that
cannot read JSON (RegisterMap.shell(); the QEMU guest scripts source them)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Sequence

from .binary import find_binary
from .registers import RegisterMap


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m candp2")
    sub = ap.add_subparsers(dest="command", required=True)
    m = sub.add_parser("map", help="the Modbus map, as JSON or as shell assignments")
    m.add_argument("--binary", help="the candp2d (default: PATH, else the build tree)")
    m.add_argument("--config", help="a configuration (default: the built-in one)")
    m.add_argument("--shell", action="store_true", help="NAME=NUMBER lines for sh")
    m.add_argument("--output", help="write here instead of to stdout")
    args = ap.parse_args(argv)
    register_map = RegisterMap.from_binary(find_binary(args.binary), args.config)
    text = (register_map.shell() if args.shell
            else json.dumps(register_map.document, indent=2) + "\n")
    if args.output:
        with open(args.output, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
