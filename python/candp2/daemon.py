"""candp2d started for a test: on free loopback ports, ready when it says so.

`Daemon(config)` writes the configuration with every listen address replaced by 127.0.0.1:0
(Modbus, HTTP (turned on), the socketcand export of every virtual bus (added where missing)),
gives every simulated drive a Modbus unit for its fault registers, starts candp2d with its own
NOTIFY_SOCKET and waits for READY=1, whose X_CANDP2_* variables name the ports the kernel chose
(docs/daemon.md "systemd"). No port is polled and none is guessed, so any number of daemons
run side by side (pytest-xdist)."""

from __future__ import annotations

import copy
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from ._notify import NotifySocket, parse_socketcand
from .binary import find_binary
from .connection import Connection
from .errors import Candp2Error, ConfigError, DaemonError, ModbusError
from .registers import RegisterMap

#: Where every listener goes: loopback, a port the kernel picks.
LOOPBACK_ANY = "127.0.0.1:0"
#: Drive units a Daemon hands out: above every DP address (the gateway clamps those to
#: 3..124, manual §2.1), below 255 (which addresses the first gateway).
DRIVE_UNITS = range(254, 124, -1)

#: Every Daemon not stopped yet (the pytest plugin reports them when a test fails).
_running: "weakref.WeakSet[Daemon]" = weakref.WeakSet()


@dataclass(frozen=True)
class HostStalls:
    """The host stalls the daemon kept from its simulated world (docs/daemon.md "Host stalls"):
    loop wakes later than `master.host_stall_ms` (SIGSTOP, a loaded host, a VM's steal time)."""

    count: int
    total_ms: float
    longest_ms: float


def running_daemons() -> list[Daemon]:
    """The Daemons of this process that have not been stopped."""
    return [d for d in _running if d.returncode is None]


def _absolute(path: str, base: Path) -> str:
    return path if os.path.isabs(path) else str(base / path)


def rewrite_config(config: Mapping[str, Any], base: Path) -> tuple[dict[str, Any], dict[str, str]]:
    """The configuration a Daemon runs (see the module docstring) and the socketcand channel of
    every virtual bus. Relative file names (the CAN log, state files, a pty link, the slaves' GSD
    files) are made absolute against `base` (the configuration file's directory,
    docs/configuration.md), since the copy lives elsewhere."""
    c: dict[str, Any] = copy.deepcopy(dict(config))
    c.setdefault("modbus", {})["listen"] = LOOPBACK_ANY
    c.setdefault("http", {})["listen"] = LOOPBACK_ANY
    channels: dict[str, str] = {}
    for name, bus in c.get("buses", {}).items():
        if isinstance(bus, dict) and bus.get("type") == "virtual":
            bus["socketcand"] = LOOPBACK_ANY
            channels[name] = str(bus.get("channel", name))
    log = c.get("log")
    if isinstance(log, dict) and isinstance(log.get("can_log"), str):
        log["can_log"] = _absolute(log["can_log"], base)
    if isinstance(c.get("state_file"), str):
        c["state_file"] = _absolute(c["state_file"], base)
    profibus = c.get("profibus")
    if isinstance(profibus, dict) and str(profibus.get("port", "")).startswith("pty:"):
        profibus["port"] = "pty:" + _absolute(profibus["port"][4:], base)
    for slave in c.get("slaves", []):
        if isinstance(slave, dict) and isinstance(slave.get("gsd"), str):
            slave["gsd"] = _absolute(slave["gsd"], base)
    drives = [d for d in c.get("drives", []) if isinstance(d, dict)]
    taken = {d.get("modbus_unit") for d in drives}
    free = (u for u in DRIVE_UNITS if u not in taken)
    for d in drives:
        if isinstance(d.get("state_file"), str):
            d["state_file"] = _absolute(d["state_file"], base)
        if "modbus_unit" not in d:
            d["modbus_unit"] = next(free)
    return c, channels


class Daemon(Connection):
    """candp2d running `config` (a dict, or the path of a JSON file), stopped by `stop()` or
    at the end of a `with` block.

    `binary` is the candp2d to run (default: `find_binary()`); `timeout` bounds the start;
    `args` are extra command-line arguments ("--log-level", "debug"); `wrapper` runs candp2d
    under another program (("chrt", "-f", "20"), ("valgrind",)). `log` is the daemon's output
    so far, `config` the configuration it runs, `config_path` where it lies.

    A configuration the daemon refuses raises ConfigError (with the JSON path of the error);
    a start that fails, or a daemon that exits while a test talks to it, raises DaemonError
    carrying the log's tail."""

    def __init__(self, config: Mapping[str, Any] | str | os.PathLike[str],
                 binary: str | os.PathLike[str] | None = None, *, timeout: float = 15.0,
                 args: tuple[str, ...] = (), wrapper: tuple[str, ...] = ()) -> None:
        self.binary = find_binary(binary)
        if isinstance(config, (str, os.PathLike)):
            source = Path(config)
            try:
                with open(source) as f:
                    loaded = json.load(f)
            except FileNotFoundError:
                raise ConfigError(str(source), None, "no such file (from %s); a shipped example "
                                  "is found from anywhere with candp2.example(\"demo.json\")"
                                  % os.getcwd(), returncode=None) from None
            base = source.resolve().parent
            #: The configuration file given (None: a dict).
            self.source: str | None = str(source)
        else:
            loaded, base = config, Path.cwd()
            self.source = None
        self.config, channels = rewrite_config(loaded, base)
        self.dir = tempfile.mkdtemp(prefix="candp2-")
        self.config_path = os.path.join(self.dir, "candp2d.json")
        self.log_path = os.path.join(self.dir, "candp2d.log")
        self.returncode: int | None = None
        self._final_log: str | None = None
        self._process: subprocess.Popen[bytes] | None = None
        self._notify: NotifySocket | None = None
        with open(self.config_path, "w") as f:
            json.dump(self.config, f, indent=2)
        try:
            register_map = RegisterMap.from_binary(self.binary, self.config_path)
            modbus, http, socketcand = self._start(timeout, (*wrapper, self.binary, "--config",
                                                             self.config_path, *args))
        except BaseException:
            self._cleanup()
            raise
        super().__init__(modbus, register_map, http=http, socketcand=socketcand,
                         channels=channels)
        _running.add(self)

    def _start(self, timeout: float, argv: tuple[str, ...]
               ) -> tuple[str, str | None, dict[str, str]]:
        notify = self._notify = NotifySocket(os.path.join(self.dir, "notify"))
        env = {k: v for k, v in os.environ.items()
               if k not in ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID", "JOURNAL_STREAM",
                            "LISTEN_FDS", "LISTEN_PID")}
        env["NOTIFY_SOCKET"] = notify.path
        try:
            with open(self.log_path, "wb") as log:
                self._process = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                                 stdin=subprocess.DEVNULL, env=env)
            deadline = time.monotonic() + timeout
            while True:
                fields = notify.receive(min(0.1, max(0.0, deadline - time.monotonic())))
                if fields and fields.get("READY") == "1":
                    break
                rc = self._process.poll()
                if rc is not None:
                    self.returncode = rc
                    while notify.receive(0.001) is not None:
                        pass
                    log_text = self.log
                    error = ConfigError.from_output(log_text, rc) if rc == 2 else None
                    if error is not None:
                        raise error
                    why = notify.last("STATUS") or "see its log"
                    raise DaemonError("candp2d exited with status %d before it was ready (%s)"
                                      % (rc, why), log_text, rc)
                if time.monotonic() >= deadline:
                    self._kill()
                    raise DaemonError("candp2d not ready within %.0f s" % timeout, self.log,
                                      self.returncode)
        except BaseException:
            self._close_notify()
            raise
        notify.drain()
        try:
            socketcand = {name: "%s:%d" % address for name, address in
                          parse_socketcand(fields.get("X_CANDP2_SOCKETCAND", "")).items()}
            return fields["X_CANDP2_MODBUS"], fields.get("X_CANDP2_HTTP"), socketcand
        except (KeyError, ValueError) as e:
            self._kill()
            raise DaemonError("READY=1 without the X_CANDP2_* addresses (%s); is candp2d older "
                              "than this package?" % e, self.log) from e

    def _close_notify(self) -> None:
        if self._notify is not None:
            self._notify.close()
            self._notify = None

    @property
    def status_line(self) -> str | None:
        """The last STATUS= the daemon sent ("1 gateway, 1 in Data_Exch, 1 Modbus client")."""
        return self._notify.last("STATUS") if self._notify else None

    @property
    def host_stalls(self) -> HostStalls:
        """The host stalls so far, from GET /api/v1/status "host_stalls"."""
        h = self.http_status()["host_stalls"]
        return HostStalls(int(h["count"]), float(h["total_ms"]), float(h["longest_ms"]))

    # ---- the process ---------------------------------------------------------------------

    @property
    def pid(self) -> int | None:
        """The daemon's process ID (None once stopped)."""
        return self._process.pid if self._process and self.returncode is None else None

    @property
    def stopped(self) -> bool:
        """stop() has run (the daemon is gone and its directory cleaned up)."""
        return self._final_log is not None

    @property
    def log(self) -> str:
        """Everything candp2d wrote so far (its log and warnings)."""
        if self._final_log is not None:
            return self._final_log
        try:
            with open(self.log_path, errors="replace") as f:
                return f.read()
        except OSError:
            return ""

    def poll(self) -> int | None:
        """The exit status if candp2d has exited, else None."""
        if self._process is not None and self.returncode is None:
            self.returncode = self._process.poll()
        return self.returncode

    def signal(self, signo: int) -> None:
        """Sends a signal (SIGHUP reopens the CAN log)."""
        if self._process is not None and self.poll() is None:
            self._process.send_signal(signo)

    def wait(self, timeout: float = 10.0) -> int:
        """Waits for candp2d to exit; its exit status."""
        assert self._process is not None
        self.returncode = self._process.wait(timeout=timeout)
        return self.returncode

    def _ideal_line_where(self) -> str:
        return " (no master.baud in %s)" % (self.source or "the configuration")

    def _face_failed(self, error: ModbusError) -> None:
        rc = self.poll()
        if rc is not None:
            raise DaemonError("candp2d exited with status %d (%s)" % (rc, error), self.log,
                              rc) from error

    def _kill(self) -> None:
        if self._process is not None and self._process.poll() is None:
            self._process.kill()
            self._process.wait(timeout=10)
        if self._process is not None:
            self.returncode = self._process.returncode

    def stop(self, timeout: float = 10.0, check: bool = True) -> int:
        """Stops candp2d with SIGTERM (SIGKILL after `timeout` s) and cleans up; its exit
        status. With `check`, raises DaemonError (with the log) when candp2d had exited by
        itself before, or did not exit with status 0."""
        already = self.poll()
        killed = False
        if self._process is not None and already is None:
            self._process.send_signal(signal.SIGTERM)
            try:
                self.returncode = self._process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self._kill()
                killed = True
        try:
            self.close()
        finally:
            log = self.log
            self._cleanup()
            self._final_log = log
            _running.discard(self)
        rc = self.returncode if self.returncode is not None else -1
        if check and already is not None:
            raise DaemonError("candp2d had exited with status %d before stop()" % already, log,
                              already)
        if check and killed:
            raise DaemonError("candp2d did not stop within %.0f s of SIGTERM" % timeout, log, rc)
        if check and rc != 0:
            raise DaemonError("candp2d exited with status %d after SIGTERM" % rc, log, rc)
        return rc

    def kill(self) -> int:
        """Kills candp2d (SIGKILL), as a crash would; its exit status. The faces stay usable
        for reading errors; call stop(check=False) to clean up."""
        self._kill()
        return self.returncode if self.returncode is not None else -1

    def _cleanup(self) -> None:
        self._close_notify()
        if os.environ.get("CANDP2_KEEP"):
            return
        shutil.rmtree(self.dir, ignore_errors=True)

    def __enter__(self) -> Daemon:
        return self

    def __exit__(self, *exc: object) -> None:
        if not self.stopped:
            self.stop(check=exc[0] is None)

    def report(self) -> str:
        """The gateways, the buses' last frames (Connection.report()) and the log's tail."""
        from .errors import log_tail
        rc = self.poll()
        status = "running" if rc is None else "exited with status %d" % rc
        parts = ["candp2d %s (%s, pid %s)" % (status, self.config_path, self.pid)]
        if rc is None:
            try:  # docs/daemon.md "Host stalls": a stall the test's world did not see
                h = self.host_stalls
                parts.append("host stalls: %d, %.1f ms in all, the longest %.1f ms"
                             % (h.count, h.total_ms, h.longest_ms))
            except (Candp2Error, OSError, KeyError) as e:
                parts.append("host stalls: unavailable (%s)" % e)
            parts.append(super().report())
        parts.append("log (last lines):\n" + log_tail(self.log))
        return "\n".join(parts)
