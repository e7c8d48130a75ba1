// The socketcand protocol (linux-can/socketcand, doc/protocol.md), raw mode, both sides.
//
// Server: exports one bus (any can::Channel the owner pumps, normally a VirtualBus endpoint) to TCP
// clients such as python-can's `socketcand` interface: greets with `< hi >`, accepts
// `< open CHANNEL >` answering `< ok >`, `< rawmode >` answering `< ok >`, then forwards every bus
// frame as `< frame ID SECONDS.USECONDS DATAHEX >` and sends every `< send ID DLC B0 B1 ... >` onto
// the bus. Unknown commands get `< error ... >`; a misbehaving client is dropped, never the daemon.
// Client: connects to a socketcand server and behaves as a can::Channel.
//
// Wire details, as socketcand itself does them (src/state_raw.c, src/state_nobus.c):
//  - identifiers are upper-case hex without 0x: 3 digits for 11-bit, 8 digits for 29-bit; in
//    `< send >` an 8-digit identifier means a 29-bit frame;
//  - `< frame >` data is upper-case, zero-padded, without spaces (`1122`; nothing for DLC 0, which
//    leaves two spaces before `>`); `< send >` data bytes are separate 1–2 digit hex words;
//  - the protocol has no remote frames: socketcand drops received RTR frames in raw mode and
//    `< send >` cannot express one. This implementation does the same (see the server and client
//    comments), so remote frames do not cross a socketcand link;
//  - error frames travel as `< error CLASS SECONDS.USECONDS >` (CLASS = can_id & CAN_ERR_MASK).
// Deliberate differences, all on input that socketcand mishandles: a `< send >` identifier with
// fewer than 8 digits but a value above 0x7FF is taken as 29-bit (python-can sends ids unpadded);
// malformed `< send >` commands are answered with `< error ... >` (socketcand ignores them
// silently); `< rawmode >` while already in raw mode answers `< ok >`.
//
// Both are driven by the caller's event loop: they expose descriptors to poll and handle readiness.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "can/channel.hpp"
#include "can/socketcan.hpp"
#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2::can {

namespace socketcand {

// Longest command element we accept. The longest valid raw-mode element,
// `< send 1FFFFFFF 8 ff ff ff ff ff ff ff ff >`, has 45 characters.
inline constexpr std::size_t kMaxElementBytes = 256;
// socketcand.h MAX_BUSNAME: bus names have at most 16 characters.
inline constexpr std::size_t kMaxBusName = 16;
inline constexpr std::uint16_t kDefaultPort = 29536;  // socketcand.h PORT

// Splits a byte stream into `< ... >` elements. Whitespace between elements is ignored. Other
// bytes outside an element are reported as Stray runs (socketcand discards them). An element
// longer than the limit is reported once as Overflow and then abandoned.
class ElementSplitter {
 public:
  enum class Kind { Element, Stray, Overflow };
  struct Item {
    Kind kind;
    std::string text;   // Element: the whole "< ... >"; Stray/Overflow: the first 64 bytes
    std::size_t bytes;  // how many input bytes the item covers
  };
  explicit ElementSplitter(std::size_t max_element = kMaxElementBytes) : max_(max_element) {}
  // Consumes all of `bytes`, appending the items it completes to `out` in stream order.
  void feed(std::string_view bytes, std::vector<Item>& out);
  std::size_t buffered() const { return partial_.size(); }

 private:
  void flush_stray(std::vector<Item>& out);
  std::size_t max_;
  std::string partial_;  // an element opened with '<', not closed yet
  bool in_element_ = false;
  std::string stray_;
  std::size_t stray_bytes_ = 0;
};

// The words between "<" and ">" ("< send 123 0 >" → send, 123, 0), split at whitespace.
std::vector<std::string_view> words(std::string_view element);

// "< frame 123 1700000000.000000 1122 >" (wall_time = microseconds since the Unix epoch).
std::string format_frame(const Frame& frame, Time wall_time);
// "< send 123 2 11 22 >" — data lower-case and unpadded as doc/protocol.md and python-can write it.
std::string format_send(const Frame& frame);

struct FrameResult {
  std::optional<Frame> frame;
  std::string error;  // meaningful when !frame; contains no '<' or '>'
};
FrameResult parse_send(std::string_view element);   // a client's `< send ... >`
FrameResult parse_frame(std::string_view element);  // a server's `< frame ... >` (raw or BCM style)
// A server's `< error CLASS SECONDS.USECONDS [DATA ...] >` as a SocketCAN error frame
// (CAN_ERR_FLAG | CLASS); nullopt for text errors such as `< error unknown command >`.
std::optional<socketcan::RawFrame> parse_error_frame(std::string_view element);

}  // namespace socketcand

class SocketcandServer {
 public:
  struct Options {
    std::string host = "127.0.0.1";                 // numeric address to bind
    std::uint16_t port = socketcand::kDefaultPort;  // 0 = pick a free one (tests)
    std::string channel = "vcan0";                  // the bus name clients must open
    std::size_t max_clients = 32;  // further connections get `< error too many clients >`
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
    std::uint64_t clients_dropped = 0;  // for misbehaviour or slowness (not normal closes)
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
};

// Connects (blocking, bounded by timeout) and completes the hi/open/rawmode handshake. `host` is an
// address or a name (name resolution itself is not bounded by the timeout). On failure
// returns nullptr and sets *error ("cannot connect to 127.0.0.1:29536: Connection refused",
// "socketcand server refused bus vcan0: could not open bus", "... timed out ...").
// The channel: poll_fd() is an epoll descriptor that becomes readable when data arrived or queued
// output can be written; call receive() until nullopt then. Remote frames cannot be sent (counted
// in tx_dropped() and logged). `< error CLASS ... >` lines from the server update bus_state();
// a lost connection reports BusOff and drops further sends (no automatic reconnect).
std::unique_ptr<Channel> connect_socketcand(const std::string& host, std::uint16_t port,
                                            const std::string& channel, std::string* error,
                                            int timeout_ms = 3000, LogSink* log = nullptr);

}  // namespace candp2::can
