// libFuzzer target: arbitrary TCP byte streams through the Modbus/TCP framing, the request decoder
// and the docs/modbus.md map. Whatever the bytes, nothing crashes, every framed request gets
// either an answer or one of the four exceptions, and a refused request changes no image byte.
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "modbus/modbus_map.hpp"

namespace {

using namespace candp2;
using namespace candp2::modbus;

struct Face : GatewayFace {
  explicit Face(std::uint8_t a) : address(a) {}
  std::uint8_t dp_address() const override { return address; }
  StatusBlock status(Time) override { return StatusBlock{}; }
  void control(Control c, Time) override {
    // The map lets only the documented commands through (docs/modbus.md: 1..4, docs/faults.md).
    if (static_cast<std::uint16_t>(c) > static_cast<std::uint16_t>(Control::MasterResumes))
      std::abort();
  }
  std::uint8_t address;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static dp::ProcessImage image;
  static Face a{5}, b{6};
  static ProcessImageMap map{image, {&a, &b}};
  MbapFramer framer;
  // Feed in two pieces to exercise partial frames.
  const std::size_t half = size / 2;
  for (const auto& piece : {std::span(data, half), std::span(data + half, size - half)}) {
    framer.append(piece);
    for (;;) {
      const auto next = framer.next();
      if (next.status != MbapFramer::Status::Frame) break;
      if (next.adu.size() < kMbapLen + 1 || next.adu.size() > kMaxAduLen) std::abort();
      auto decoded = decode_request(next.adu);
      if (auto* r = std::get_if<Request>(&decoded)) {
        const auto before = image;
        ReadResult out;
        if (const auto failure = map.handle(*r, out, Time{0})) {
          if (std::memcmp(&before, &image, sizeof image) != 0) std::abort();
          if (failure->exception != Exception::IllegalDataAddress &&
              failure->exception != Exception::IllegalDataValue &&
              failure->exception != Exception::GatewayTargetFailed)
            std::abort();
        }
      }
    }
  }
  return 0;
}
