"""Shared by the HTTP face's end-to-end tests (http_api_e2e.py, http_chromium_e2e.py).

Starts candp2d on config/demo.json with every listener on port 0 (the kernel picks free ports, so
parallel test runs never collide) and reads the ports from the daemon's "ready: modbus
127.0.0.1:P, http 127.0.0.1:Q, ..." log line, waiting for it with a deadline.
"""

import json
import os
import re
import subprocess
import tempfile
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class Daemon:
    def __init__(self, candp2d, config=None, timeout=15.0, prefix=()):
        self.dir = tempfile.mkdtemp(prefix="candp2-http-")
        if config is None:
            with open(os.path.join(ROOT, "config", "demo.json")) as f:
                config = json.load(f)
            config["modbus"]["listen"] = "127.0.0.1:0"
            config["http"] = {"listen": "127.0.0.1:0"}
            config["buses"]["can0"]["socketcand"] = "127.0.0.1:0"
        self.config_path = os.path.join(self.dir, "candp2d.json")
        with open(self.config_path, "w") as f:
            json.dump(config, f)
        self.log_path = os.path.join(self.dir, "candp2d.log")
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen(list(prefix) + [candp2d, "--config", self.config_path],
                                     stdout=self.log, stderr=subprocess.STDOUT)
        end = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                raise SystemExit("FAIL: candp2d exited with %s:\n%s" % (self.proc.returncode,
                                                                         self.text()))
            m = re.search(r"ready: modbus [\d.]+:(\d+), http [\d.]+:(\d+)", self.text())
            if m:
                self.modbus_port, self.http_port = int(m.group(1)), int(m.group(2))
                break
            if time.monotonic() > end:
                self.stop()
                raise SystemExit("FAIL: no ready line from candp2d:\n" + self.text())
            time.sleep(0.02)
        self.base = "http://127.0.0.1:%d" % self.http_port

    def text(self):
        with open(self.log_path) as f:
            return f.read()

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
                raise SystemExit("FAIL: %s within %.0f s; last status:\n%s"
                                 % (what, timeout, json.dumps(s)[:2000]))
            time.sleep(0.02)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
