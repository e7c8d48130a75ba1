"""The daemon's HTTP face, read-only: GET /api/v1/status (docs/daemon.md "HTTP face")."""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from typing import Any, Mapping

from .errors import Candp2Error


class HttpFace:
    """GETs from one candp2d's HTTP face at `base` ("http://127.0.0.1:8080")."""

    def __init__(self, base: str, timeout: float = 5.0) -> None:
        self.base = base.rstrip("/")
        self.timeout = timeout

    def get(self, path: str) -> bytes:
        """The body of GET `path`; Candp2Error for anything but 200."""
        try:
            with urllib.request.urlopen(self.base + path, timeout=self.timeout) as r:
                body: bytes = r.read()
                return body
        except (urllib.error.URLError, OSError) as e:
            raise Candp2Error("GET %s%s: %s" % (self.base, path, e)) from e

    def status(self) -> Mapping[str, Any]:
        """GET /api/v1/status, parsed."""
        doc: Mapping[str, Any] = json.loads(self.get("/api/v1/status"))
        return doc
