// socketcand server: exports one bus to TCP clients (see socketcand.hpp for the protocol).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "can/channel.hpp"
#include "can/socketcand_protocol.hpp"
#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2::can {

class SocketcandServer {
 public:
  struct Options {
    std::string host = "127.0.0.1";                 // numeric address to bind
    std::uint16_t port = socketcand::kDefaultPort;  // 0 = pick a free one (tests)
    std::string channel = "vcan0";                  // the bus name clients must open
    // At the limit a new connection evicts a client: the one idle longest among those that have
    // not opened the bus in raw mode, else the raw-mode client whose last command is oldest.
    std::size_t max_clients = 32;
    // A client that has not reached raw mode within this time of its last command is closed;
    // raw-mode clients receive bus traffic and are never closed for idleness. 0 = never.
    Duration idle_timeout = seconds(60);
    // A client is dropped (after a log line) when one command exceeds max_command_bytes, when it
    // sent more than max_stray_bytes outside `< >` in total, or when more than max_output_bytes
    // wait in its output buffer (it does not read: slow clients never block the loop).
    std::size_t max_command_bytes = socketcand::kMaxElementBytes;
    std::size_t max_stray_bytes = 256;
    std::size_t max_output_bytes = 1 << 20;
  };
  struct Stats {
    std::uint64_t frames_to_clients = 0;      // bus frames published (counted once per frame)
    std::uint64_t frames_from_clients = 0;    // valid `< send >` put onto the bus
    std::uint64_t remote_frames_skipped = 0;  // RTR frames the protocol cannot carry
    std::uint64_t clients_accepted = 0;
    std::uint64_t clients_dropped = 0;    // for misbehaviour or slowness (not normal closes)
    std::uint64_t clients_evicted = 0;    // closed to make room at max_clients
    std::uint64_t clients_timed_out = 0;  // closed after idle_timeout before raw mode
  };
  // `bus` is where frames sent by clients go; the owner feeds bus traffic with publish().
  static std::unique_ptr<SocketcandServer> listen(Options options, FrameSink& bus, LogSink* log,
                                                  std::string* error);
  virtual ~SocketcandServer() = default;
  virtual std::uint16_t port() const = 0;  // the bound port
  // Descriptors to poll for readability. The server multiplexes its listening socket and all
  // clients (including their write readiness) behind one internal epoll descriptor, so this is a
  // single descriptor that stays the same for the server's lifetime.
  virtual std::vector<int> poll_fds() const = 0;
  // Call when any of poll_fds() is readable (or periodically); accepts, reads, writes, dispatches.
  // `now` is the wall-clock time (µs since the Unix epoch) stamped on frames that one client sends
  // and the server forwards to the other raw-mode clients (a raw socket per client in socketcand
  // sees the others' frames; the sender does not see its own).
  virtual void on_readable(int fd, Time now) = 0;
  // A frame seen on the bus (wall_time as above): forwarded to every client in raw mode. Frames
  // that clients sent come back to the owner's endpoint only if it receives its own; the server
  // already forwarded them to the other clients, so do not publish them again. Remote frames are
  // not forwarded (the protocol has none) and are counted in Stats::remote_frames_skipped.
  virtual void publish(const Frame& frame, Time wall_time) = 0;
  virtual std::size_t client_count() const = 0;
  virtual Stats stats() const = 0;
  // Idle timeouts: when advance() must run next, in the clock of on_readable()'s `now`.
  virtual std::optional<Time> next_deadline() const = 0;
  virtual void advance(Time now) = 0;
};

}  // namespace candp2::can
