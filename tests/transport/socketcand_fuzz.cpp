// libFuzzer target: arbitrary bytes through the socketcand element splitter and every parser a
// server or client applies to what a peer sends. Nothing may crash, memory stays bounded, and
// whatever parses must format back into something that parses to the same frame.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "can/socketcand.hpp"

using namespace candp2::can;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  socketcand::ElementSplitter splitter;
  std::vector<socketcand::ElementSplitter::Item> items;
  // Feed in two pieces to exercise elements split across reads.
  const std::size_t cut = size ? data[0] % (size + 1) : 0;
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  splitter.feed(all.substr(0, cut), items);
  splitter.feed(all.substr(cut), items);
  if (splitter.buffered() > socketcand::kMaxElementBytes) std::abort();
  for (const auto& item : items) {
    if (item.kind != socketcand::ElementSplitter::Kind::Element) continue;
    (void)socketcand::words(item.text);
    (void)socketcand::parse_error_frame(item.text);
    if (auto r = socketcand::parse_send(item.text); r.frame) {
      const auto again = socketcand::parse_send(socketcand::format_send(*r.frame));
      if (!again.frame || !(*again.frame == *r.frame)) std::abort();
    }
    if (auto r = socketcand::parse_frame(item.text); r.frame) {
      const auto again = socketcand::parse_frame(socketcand::format_frame(*r.frame, {}));
      if (!again.frame || !(*again.frame == *r.frame)) std::abort();
    }
  }
  return 0;
}
