"""A thin Modbus/TCP client over Debian's pymodbus: requests split at the map's size limits,
exception answers raised as ModbusError with the daemon's own names for them."""

from __future__ import annotations

from typing import Any, Callable, Iterator, Sequence

from pymodbus.client import ModbusTcpClient  # python3-pymodbus
from pymodbus.exceptions import ModbusException

from .errors import ModbusError
from .registers import RegisterMap


def _chunks(address: int, count: int, limit: int) -> Iterator[tuple[int, int]]:
    """(first address, count) of each request that covers `count` items from `address` in
    requests of at most `limit` items."""
    for offset in range(0, count, limit):
        yield address + offset, min(limit, count - offset)


class ModbusFace:
    """One connection to a candp2d's Modbus/TCP face.

    `on_failure` is called (with the ModbusError about to be raised) when a request gets no
    answer at all, so that the owner can say why (a Daemon raises with the log tail when
    candp2d has exited)."""

    def __init__(self, host: str, port: int, register_map: RegisterMap, timeout: float = 3.0,
                 on_failure: Callable[[ModbusError], None] | None = None) -> None:
        self.host = host
        self.port = port
        self.map = register_map
        self.on_failure = on_failure
        self.client = ModbusTcpClient(host, port=port, timeout=timeout, retries=1)

    def close(self) -> None:
        self.client.close()

    def _call(self, what: str, request: Callable[[], Any]) -> Any:
        try:
            response = request()
        except ModbusException as e:
            error = ModbusError(what, None, "no answer from %s:%d (%s)" % (self.host, self.port, e))
            if self.on_failure:
                self.on_failure(error)
            raise error from e
        if response is None or response.isError():
            code = getattr(response, "exception_code", None)
            if isinstance(code, int) and code > 0:
                raise ModbusError(what, code, self.map.exception_name(code))
            error = ModbusError(what, None, "no answer from %s:%d (%s)"
                                % (self.host, self.port, response))
            if self.on_failure:
                self.on_failure(error)
            raise error
        return response

    # ---- registers ---------------------------------------------------------------------------

    def read_registers(self, table: str, address: int, count: int, unit: int) -> list[int]:
        """`count` registers of "holding_registers" or "input_registers" from `address`,
        in requests of at most the map's read limit."""
        read = (self.client.read_input_registers if table == "input_registers"
                else self.client.read_holding_registers)
        out: list[int] = []
        for a, n in _chunks(address, count, self.map.limits["read_registers"]):
            r = self._call("read %s %d..%d (unit %d)" % (table.replace("_", " "), a, a + n - 1,
                                                         unit),
                           lambda: read(a, n, slave=unit))
            out += [int(v) for v in r.registers[:n]]
        return out

    def write_registers(self, address: int, values: Sequence[int], unit: int) -> None:
        """Holding registers from `address` (FC 16), in requests of at most the write limit."""
        values = list(values)
        for a, n in _chunks(address, len(values), self.map.limits["write_registers"]):
            chunk = values[a - address:a - address + n]
            self._call("write holding registers %d..%d (unit %d)" % (a, a + n - 1, unit),
                       lambda: self.client.write_registers(a, chunk, slave=unit))

    def write_register(self, address: int, value: int, unit: int) -> None:
        """One holding register (FC 6)."""
        self._call("write holding register %d = %d (unit %d)" % (address, value, unit),
                   lambda: self.client.write_register(address, value, slave=unit))

    # ---- bits --------------------------------------------------------------------------------

    def write_coils(self, address: int, bits: Sequence[bool], unit: int) -> None:
        """Coils from `address` (FC 15), in requests of at most the write limit."""
        bits = list(bits)
        for a, n in _chunks(address, len(bits), self.map.limits["write_bits"]):
            chunk = bits[a - address:a - address + n]
            self._call("write coils %d..%d (unit %d)" % (a, a + n - 1, unit),
                       lambda: self.client.write_coils(a, chunk, slave=unit))
