// Modbus/TCP server inside the daemon's one event loop (docs/modbus.md), on libmodbus.
//
// libmodbus's own receive path (modbus_receive) blocks in select() until a whole request has
// arrived and frames by function code rather than by the MBAP length, so one slow or broken client
// would stall the loop and every other client. This server therefore reads each client's socket
// itself (non-blocking) and frames by the MBAP header (modbus_map.hpp, MbapFramer); libmodbus
// creates the listening socket and builds and sends every answer (modbus_reply with a mapping
// filled for that one request, modbus_reply_exception). Requests are validated before they reach
// libmodbus, so its own exception paths — which sleep and flush the socket on bad quantities —
// are never taken.
//
// A client that sends garbage (not Modbus/TCP framing) or does not read its answers is dropped
// with a log line; the server serves on. Idle clients cannot lock others out: at max_clients a new
// connection evicts the client idle longest, and a client silent for idle_timeout is closed
// (common/idle_clients.hpp). Many clients at once; each request is handled completely
// inside one callback, so it never interleaves with a master cycle.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "common/log.hpp"
#include "event_loop/event_loop.hpp"
#include "modbus/modbus_map.hpp"

namespace candp2::modbus {

class ModbusServer {
 public:
  struct Options {
    std::string host = "127.0.0.1";  // numeric IPv4; "0.0.0.0" = every interface
    std::uint16_t port = 1502;       // 0 = any free port (see port())
    // At the limit a new connection evicts the client idle longest (docs/modbus.md).
    std::size_t max_clients = 64;
    // A client without a request for this long is closed; 0 = never.
    Duration idle_timeout = seconds(60);
    int backlog = 128;  // connection bursts queue instead of retrying SYNs after 1 s
    // The time requests are handled at (the plant's: candp2d's simulated clock, docs/daemon.md
    // "Host stalls"). Empty: the loop's.
    std::function<Time()> now = {};
  };
  struct Stats {
    std::uint64_t requests = 0;    // answered normally
    std::uint64_t exceptions = 0;  // answered with an exception
    std::uint64_t clients_accepted = 0;
    std::uint64_t clients_refused = 0;    // not served (no connection could be evicted)
    std::uint64_t clients_evicted = 0;    // closed to make room for a new one (idle longest)
    std::uint64_t clients_timed_out = 0;  // closed after idle_timeout without a request
    std::uint64_t clients_dropped = 0;    // for garbage or not reading
  };

  // nullptr and *error ("cannot listen on 127.0.0.1:1502: Address already in use") on failure.
  static std::unique_ptr<ModbusServer> listen(Options options, EventLoop& loop, Handler& handler,
                                              LogSink* log, std::string* error);
  virtual ~ModbusServer() = default;
  virtual std::uint16_t port() const = 0;
  virtual std::size_t client_count() const = 0;
  virtual const Stats& stats() const = 0;
};

}  // namespace candp2::modbus
