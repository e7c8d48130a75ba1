"""A tiny Chrome DevTools Protocol client on the Python standard library (no npm, no pip):
launches Debian's chromium headless with a fresh profile and --remote-debugging-port=0, finds the
page target through the DevTools HTTP endpoint and talks JSON-RPC over a minimal RFC 6455
websocket (client frames masked, text frames only, no extensions).

Used by http_chromium_e2e.py and bench/http_jitter.py. Every wait has a deadline; close() kills
the browser's process group (the processes this module started, by id).
"""

import base64
import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import tempfile
import time
import urllib.request

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--disable-extensions",
                  "--disable-default-apps", "--mute-audio", "--hide-scrollbars",
                  "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0"]


class Browser:
    def __init__(self, chromium="/usr/bin/chromium", width=1400, height=1000, timeout=30.0):
        self.profile = tempfile.mkdtemp(prefix="candp2-chromium-")
        self.proc = subprocess.Popen(
            [chromium] + CHROMIUM_FLAGS + ["--user-data-dir=" + self.profile,
                                           "--window-size=%d,%d" % (width, height), "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        port_file = os.path.join(self.profile, "DevToolsActivePort")
        end = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError("chromium exited with %s" % self.proc.returncode)
            try:
                with open(port_file) as f:
                    lines = f.read().split()
                if len(lines) >= 2:
                    self.port = int(lines[0])
                    break
            except (OSError, ValueError):
                pass
            if time.monotonic() > end:
                raise RuntimeError("chromium did not open its DevTools port")
            time.sleep(0.05)
        while True:
            with urllib.request.urlopen("http://127.0.0.1:%d/json/list" % self.port,
                                        timeout=5) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            if pages:
                break
            if time.monotonic() > end:
                raise RuntimeError("chromium shows no page target")
            time.sleep(0.05)
        self.ws = _WebSocket(pages[0]["webSocketDebuggerUrl"], timeout)
        self.next_id = 0

    def call(self, method, timeout=20.0, **params):
        self.next_id += 1
        mid = self.next_id
        self.ws.send(json.dumps({"id": mid, "method": method, "params": params}))
        end = time.monotonic() + timeout
        while True:
            msg = json.loads(self.ws.recv(max(0.05, end - time.monotonic())))
            if msg.get("id") == mid:
                if "error" in msg:
                    raise RuntimeError("%s: %s" % (method, msg["error"]))
                return msg.get("result", {})
            if time.monotonic() > end:
                raise RuntimeError("no answer to " + method)

    def evaluate(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                      awaitPromise=True)
        if "exceptionDetails" in r:
            return None
        return r["result"].get("value")

    def wait_for(self, what, expression, timeout=20.0):
        end = time.monotonic() + timeout
        while True:
            v = self.evaluate(expression)
            if v:
                return v
            if time.monotonic() > end:
                raise SystemExit("FAIL: the page never showed %s (%s)" % (what, expression))
            time.sleep(0.1)

    def screenshot(self, path):
        r = self.call("Page.captureScreenshot", format="png")
        with open(path, "wb") as f:
            f.write(base64.b64decode(r["data"]))

    def screenshot_page(self, path, width=1400):
        """The whole page in one viewport (parts painted beyond the viewport lose their
        styling), at most 8000 pixels high; the viewport is restored after."""
        height = int(self.evaluate("document.documentElement.scrollHeight"))
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=min(height, 8000),
                  deviceScaleFactor=1, mobile=False)
        self.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        self.screenshot(path)
        self.call("Emulation.clearDeviceMetricsOverride")

    def keep_page(self, path):
        """screenshot_page() to `path`, asserted not blank (a dark page of text is > 10 kB)."""
        self.screenshot_page(path)
        assert os.path.getsize(path) > 10000, os.path.getsize(path)
        print("screenshot: " + path)

    def close(self):
        try:
            self.ws.close()
        except Exception:  # the browser may already be gone
            pass
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        shutil.rmtree(self.profile, ignore_errors=True)


class _WebSocket:
    def __init__(self, url, timeout):
        assert url.startswith("ws://"), url
        hostport, _, path = url[5:].partition("/")
        host, _, port = hostport.partition(":")
        self.sock = socket.create_connection((host, int(port)), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(("GET /%s HTTP/1.1\r\nHost: %s\r\nUpgrade: websocket\r\n"
                           "Connection: Upgrade\r\nSec-WebSocket-Key: %s\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n" % (path, hostport, key)).encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise RuntimeError("websocket handshake: connection closed")
            head += chunk
        head, _, self.buf = head.partition(b"\r\n\r\n")
        if b" 101 " not in head.split(b"\r\n")[0]:
            raise RuntimeError("websocket handshake refused: %r" % head[:200])

    def send(self, text):
        data = text.encode()
        mask = os.urandom(4)
        n = len(data)
        if n < 126:
            header = struct.pack("!BB", 0x81, 0x80 | n)
        elif n < 65536:
            header = struct.pack("!BBH", 0x81, 0x80 | 126, n)
        else:
            header = struct.pack("!BBQ", 0x81, 0x80 | 127, n)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(data))
        self.sock.sendall(header + mask + masked)

    def _read(self, n, end):
        while len(self.buf) < n:
            self.sock.settimeout(max(0.01, end - time.monotonic()))
            chunk = self.sock.recv(1 << 20)
            if not chunk:
                raise RuntimeError("websocket closed")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def recv(self, timeout):
        end = time.monotonic() + timeout
        message = b""
        while True:
            b0, b1 = self._read(2, end)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack("!H", self._read(2, end))[0]
            elif n == 127:
                n = struct.unpack("!Q", self._read(8, end))[0]
            payload = self._read(n, end)  # servers do not mask
            opcode = b0 & 0x0F
            if opcode == 8:
                raise RuntimeError("websocket closed by the browser")
            if opcode in (0, 1, 2):
                message += payload
                if b0 & 0x80:
                    return message.decode()

    def close(self):
        self.sock.close()
