// socketcand client: a can::Channel on a remote socketcand server (see socketcand.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "can/channel.hpp"
#include "can/socketcand_protocol.hpp"
#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2::can {

// Connects (blocking, bounded by timeout) and completes the hi/open/rawmode handshake. `host` is an
// address or a name (name resolution itself is not bounded by the timeout). On failure
// returns nullptr and sets *error ("cannot connect to 127.0.0.1:29536: Connection refused",
// "socketcand server refused bus vcan0: could not open bus", "... timed out ...").
// The channel: poll_fd() is an epoll descriptor that becomes readable when data arrived or queued
// output can be written; call receive() until nullopt then. Remote frames cannot be sent (counted
// in tx_dropped() and logged). `< error CLASS ... >` lines from the server update bus_state();
// a lost connection reports BusOff and drops further sends until it is re-established (above).
// The channel connect_socketcand() returns, for owners that show its connection statistics.
class SocketcandClientChannel : public Channel {
 public:
  // Connections re-established after the server went away.
  std::uint32_t reconnects() const override = 0;
  // Reconnection: after the connection is lost the channel reports bus-off, drops
  // sends, and tries again after 100 ms, doubling to at most 5 s (reset after a successful
  // connection); each attempt is a non-blocking connect (completion seen through poll_fd()) and the
  // hi/open/rawmode handshake, bounded by 3 s. The owner calls advance() at next_deadline(), in
  // CLOCK_MONOTONIC microseconds (EventLoop::monotonic_now), and drains receive() when poll_fd()
  // is readable.
  virtual std::optional<Time> next_deadline() const = 0;
  virtual void advance(Time now) = 0;
};

std::unique_ptr<Channel> connect_socketcand(const std::string& host, std::uint16_t port,
                                            const std::string& channel, std::string* error,
                                            int timeout_ms = 3000, LogSink* log = nullptr);

}  // namespace candp2::can
