"""Shared by the HTTP face's end-to-end tests (http_api_e2e.py, http_chromium_e2e.py) and
bench/http_jitter.py: a candp2.Daemon (python/: every listener on a free loopback port, learnt
from READY=1) with helpers for its HTTP face.
"""

import json
import os
import sys
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python"))
import candp2  # noqa: E402


def demo_config():
    """config/demo.json (the Daemon moves its listeners to free ports)."""
    with open(os.path.join(ROOT, "config", "demo.json")) as f:
        return json.load(f)


class Daemon(candp2.Daemon):
    """candp2d running `config` (default: config/demo.json); `prefix` runs it under another
    program (chrt)."""

    def __init__(self, candp2d, config=None, timeout=15.0, prefix=()):
        super().__init__(demo_config() if config is None else config, candp2d,
                         timeout=timeout, wrapper=tuple(prefix))
        self.modbus_port = self.modbus_address[1]
        self.http_port = self.http_address[1]
        self.base = self.http_url

    def get(self, path, method="GET", timeout=5.0):
        """(status, headers, body bytes); HTTP errors are returned, not raised."""
        req = urllib.request.Request(self.base + path, method=method,
                                     data=b"x" if method in ("POST", "PUT") else None)
        try:
            with urllib.request.urlopen(req, timeout=timeout) as r:
                return r.status, r.headers, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers, e.read()

    def status(self):
        code, _, body = self.get("/api/v1/status")
        assert code == 200, code
        return json.loads(body)

    def wait_for(self, what, predicate, timeout=10.0):
        """Polls /api/v1/status until predicate(status) is true (then returns the status)."""
        end = time.monotonic() + timeout
        while True:
            s = self.status()
            if predicate(s):
                return s
            if time.monotonic() > end:
                raise AssertionError("%s not within %.0f s; last status:\n%s"
                                     % (what, timeout, json.dumps(s)[:2000]))
            time.sleep(0.02)

    def stop(self, timeout=10.0, check=False):
        return super().stop(timeout, check)
