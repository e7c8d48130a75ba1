// The socketcand protocol (linux-can/socketcand, doc/protocol.md), raw mode: pure framing and
// formatting, no sockets (framing as pure functions, apart from each transport). The
// server (socketcand_server.hpp) and the client (socketcand_client.hpp) build on it; the wire
// details and our deliberate differences are listed in socketcand.hpp.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "can/frame.hpp"
#include "can/socketcan.hpp"
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

}  // namespace candp2::can
